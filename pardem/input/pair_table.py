"""The ``[[contact.pair]]`` tables of a scene: the contact parameters of one pair of species, or
of a species and a ring, and their checks.

Stage: input (called by ``schema.scene_from_dict``). A pair table names its two partners in
``species`` and gives any of the [contact] keys of the scene's normal law and switched-on
slots; a key it leaves out takes the [contact] value, and a pair without a table mixes its
partners' own laws (contact/pairs.py). Errors name the table by its number and
partners, and the key.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from ..contact.keys import check_law, check_slots
from ..contact.pairs import BOUNDARIES
from .scene import Contact, PairLaw, SceneError
from .values import FLOAT, fail, rule_ok, show, value

SCENE_KEYS = ("normal", "mu_bottom", "gravity", "height")
"""[contact] keys that describe the scene, not a contact: one value for every pair."""

PAIR_KEYS = tuple(f.name for f in dataclasses.fields(Contact) if f.name not in SCENE_KEYS)


def check_pairs(rows: Any, c: dict, given: dict, e: dict,
                partners: tuple) -> tuple[PairLaw, ...]:
    """The validated pair tables of a scene whose [contact] table is ``c`` (every key, defaults
    filled in; ``given``: the keys the scene wrote) and [effects] ``e``; ``partners``: the
    names a table may give in ``species`` (couette: the species' names and BOUNDARIES; free:
    the particles' species numbers)."""
    if not isinstance(rows, list) or not rows:
        raise SceneError(f"[[contact.pair]]: expected a non-empty array of tables, got "
                         f"{show(rows)}")
    seen: dict[frozenset, int] = {}
    out = []
    for i, row in enumerate(rows):
        label = f"[[contact.pair]] #{i}"
        if not isinstance(row, dict):
            raise SceneError(f"{label}: expected a table, got {show(row)}")
        pair = _partners(label, row.get("species"), partners)
        label = f"[[contact.pair]] #{i} {show(pair[0])}-{show(pair[1])}"
        if frozenset(pair) in seen:
            raise SceneError(f"{label}: the pair is given twice (also table "
                             f"#{seen[frozenset(pair)]}); give each pair once, in either order")
        seen[frozenset(pair)] = i
        values = {k: _value(label, k, v) for k, v in row.items() if k != "species"}
        if not values:
            raise SceneError(f"{label}: no parameters; give at least one of "
                             f"{', '.join(PAIR_KEYS)}")
        for name in ("restitution", "tangential_restitution"):
            if name in values and c[name] is None:
                raise fail(label, name, values[name], f"needs [contact] {name}: a scene gives "
                           "its damping one way, for every pair")
        merged = {**c, **values}
        try:
            check_slots(merged, e)
            check_law(merged, set(values) | set(given))
        except SceneError as err:
            raise SceneError(f"{label}: {str(err).replace('[contact] ', '', 1)}") from None
        out.append(PairLaw(pair, tuple(values.items())))
    return tuple(out)


def _partners(label: str, names: Any, partners: tuple) -> tuple:
    """The two partners of a table's ``species`` list, each one of ``partners``."""
    if not (isinstance(names, list) and len(names) == 2):
        raise SceneError(f"{label} species = {show(names)}: expected a list of two partners, "
                         f"e.g. species = [{', '.join(show(p) for p in partners[:2])}]")
    for name in names:
        if isinstance(name, (bool, float)) or name not in partners:
            raise fail(label, "species", names, f"{show(name)} is not a species of this scene "
                       f"(allowed: {', '.join(show(p) for p in partners)})")
    if names[0] in BOUNDARIES and names[1] in BOUNDARIES:
        raise fail(label, "species", names, "two rings never touch; name a species")
    if names[1] not in BOUNDARIES and (names[0] in BOUNDARIES
                                       or partners.index(names[1]) < partners.index(names[0])):
        names = names[::-1]  # stored in the order of the scene's species, a ring second
    return tuple(names)


def _value(label: str, key: str, v: Any) -> float:
    """One parameter of a pair table: a [contact] key of a contact, of its kind and rule."""
    if key in SCENE_KEYS:
        raise fail(label, key, v, "is a property of the scene, not of a pair; give it in "
                   "[contact]")
    if key not in PAIR_KEYS:
        raise SceneError(f"{label} unknown key {key!r}; allowed: species, {', '.join(PAIR_KEYS)}")
    f = Contact.__dataclass_fields__[key]
    got = value(label, key, v, FLOAT, f.metadata["unit"])
    ok, why = rule_ok(got, f.metadata["rule"])
    if not ok:
        raise fail(label, key, v, why, f.metadata["unit"])
    return got

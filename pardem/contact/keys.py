"""Which [contact] keys a scene may give: the optional slots' parameters, each only with its
[effects] switch (``check_slots``), and the normal law's, each only with its law
(``check_law``, ``foreign_keys``; the laws' descriptors in normal.py declare them).

Stage: input (schema.scene_from_dict calls the checks; Scene.to_dict writes only the keys the
scene's law uses).
"""

from __future__ import annotations

from ..input.errors import SceneError
from ..input.values import fail
from .normal import LAWS


# an optional slot's [effects] switch -> (the effect it needs and why, its [contact] parameters
# that must be > 0 when on, its other parameters); none may be set while the slot is off
SLOT_KEYS = {
    "tangential_damping": ("tangential_friction", "it damps the tangential spring",
                           ("gamma_t",), ()),
    "rolling_resistance": ("rotation", "it resists the disks' relative rotation", ("k_r",),
                           ("mu_r",)),
}
PARAMETER_UNITS = {"gamma_t": "kg/s", "k_r": "N/m", "mu_r": ""}
RESTITUTIONS = {"restitution": ("normal_damping", "gamma_n"),
                "tangential_restitution": ("tangential_damping", "gamma_t")}
"""A restitution key -> its damping's [effects] switch and the coefficient it replaces."""


def check_slots(c: dict, e: dict) -> None:
    """SceneError unless every switched-on slot has its parameters ([contact] c and [effects]
    e as dicts), and no slot's parameter is set while the slot is off."""
    for name, (switch, _) in RESTITUTIONS.items():
        if c.get(name) is not None and not e[switch]:
            raise fail("[contact]", name, c[name], f"is set but [effects] {switch} is off; "
                       f"switch it on or remove {name}")
    if c.get("tangential_restitution") is not None and not e["rotation"]:
        raise fail("[contact]", "tangential_restitution", c["tangential_restitution"],
                   "assumes turning disks (a sticking contact's mass is m_red/3: "
                   "contact/damping.py); [effects] rotation is off: give gamma_t")
    if e["tangential_friction"] and c["mu"] > 0 and c["k_t"] <= 0:
        raise fail("[contact]", "k_t", c["k_t"], "must be > 0 when [effects] "
                   "tangential_friction is on and mu > 0", "N/m")
    replaced = {gamma for name, (_, gamma) in RESTITUTIONS.items() if c.get(name) is not None}
    for switch, (needs, why, positive, optional) in SLOT_KEYS.items():
        if e[switch]:
            if not e[needs]:
                raise fail("[effects]", switch, True, f"needs [effects] {needs} = true ({why})")
            for name in positive:
                if not c[name] > 0 and name not in replaced:
                    raise fail("[contact]", name, c[name], f"must be > 0 when [effects] "
                               f"{switch} is on", PARAMETER_UNITS[name])
            continue
        for name in positive + optional:
            if c[name] != 0:
                raise fail("[contact]", name, c[name], f"is set but [effects] {switch} is off; "
                           f"switch it on or remove {name}", PARAMETER_UNITS[name])


def foreign_keys(name: str) -> set[str]:
    """The [contact] keys a scene with ``normal = name`` may not give: the other laws'
    parameters, and k_t where the law sets the tangential stiffness itself."""
    law = LAWS[name]
    return ({k for other in LAWS.values() for k in other.keys if k not in law.keys}
            | ({"k_t"} if law.tangential else set()))


def check_law(c: dict, given) -> None:
    """SceneError unless the [contact] table ``c`` (every key, defaults filled in) gives the
    parameters of its normal law and none of another's (``given``: the keys the scene wrote)."""
    law = LAWS[c["normal"]]
    for other in LAWS.values():
        for name in other.keys:
            if name in given and name not in law.keys:
                raise fail("[contact]", name, c[name], f'is a parameter of normal = '
                           f'"{other.name}"; this scene\'s normal law is "{law.name}" (its own '
                           f"parameters: {', '.join(law.keys)})")
    if law.tangential and "k_t" in given:
        raise fail("[contact]", "k_t", c["k_t"], f'normal = "{law.name}" sets the tangential '
                   "stiffness from its own parameters (Mindlin); remove k_t")
    for name in law.required:
        if name not in given:
            raise SceneError(f'[contact] {name}: missing (required with normal = "{law.name}")')
    if law.check is not None:
        law.check(c)
    if c.get("restitution") is not None:
        _check_restitution(c, given, law)
    if c.get("tangential_restitution") is not None:
        _check_tangential_restitution(c, given, law)


def _check_restitution(c: dict, given, law) -> None:
    """A restitution replaces gamma_n, needs a law with its closed form (and normal damping:
    check_damping)."""
    if "gamma_n" in given:
        raise fail("[contact]", "restitution", c["restitution"], "gamma_n is given too; give "
                   "one of them (the restitution sets each contact's gamma_n from its masses)")
    if not law.restitution:
        laws = ", ".join(f'"{x.name}"' for x in LAWS.values() if x.restitution)
        raise fail("[contact]", "restitution", c["restitution"], f'is defined for normal = '
                   f'{laws}; give gamma_n with normal = "{law.name}"')


def _check_tangential_restitution(c: dict, given, law) -> None:
    """e_t replaces gamma_t and needs a constant k_t (and turning disks: check_slots)."""
    e_t = c["tangential_restitution"]
    if "gamma_t" in given:
        raise fail("[contact]", "tangential_restitution", e_t, "gamma_t is given too; give one "
                   "of them (e_t sets each contact's gamma_t from its masses)")
    if law.tangential:
        raise fail("[contact]", "tangential_restitution", e_t, f'needs a constant k_t; normal = '
                   f'"{law.name}" scales it with the contact radius: give gamma_t')

"""The manual's input reference (``docs/input.md``) generated from the scene schema: every
table, key, kind, unit, default and allowed values, from the declarations in
``pardem/input/scene.py`` (one source; ``tests/test_manual.py`` checks that the page is current).

    python run_scripts/tools/input_reference.py            # writes docs/input.md
    python run_scripts/tools/input_reference.py --check    # exit 1 if docs/input.md is stale
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import sys
from dataclasses import MISSING
from pathlib import Path

from pardem.contact.normal import LAWS
from pardem.contact.pairs import BOUNDARIES
from pardem.input.pair_table import PAIR_KEYS, SCENE_KEYS
from pardem.input.scene import (AveragingCfg, Contact, Effects, FreeParticles, Geometry, Neighbors,
                                OutputCfg, PairLaw, SceneInfo, Species, TimeCfg, WarningsCfg,
                                _PUNITS)

PAGE = Path(__file__).resolve().parents[2] / "docs" / "input.md"
TABLES = (("[scene]", SceneInfo, "required"), ("[geometry]", Geometry, "couette scenes"),
          ("[[species]]", Species, "couette scenes: one table per species, at least one"),
          ("[contact]", Contact, "optional"), ("[effects]", Effects, "optional"),
          ("[time]", TimeCfg, "optional"), ("[neighbors]", Neighbors, "optional"),
          ("[output]", OutputCfg, "optional"),
          ("[averaging]", AveragingCfg, "optional: in-situ ring averaging of couette scenes"),
          ("[warnings]", WarningsCfg, "optional: when a run warns (docs/warnings.md)"))
KINDS = {"float": "number", "int": "integer", "bool": "true / false", "str": "string",
         "float | None": 'number or "auto"', "int | None": 'integer or "auto"',
         "float | bool": "number or `false`"}

INTRO = """# Input reference

A scene is a TOML file. `pardem check SCENE.toml` prints it resolved (every default filled
in) with its time step and an estimated run time; `pardem run` stores the resolved scene with
the run (`DIR/scene.toml`). Units are SI throughout: m, kg, s, rad, N. A key that is not listed
here, a value of the wrong kind or outside what is allowed is refused with one line naming the
table, the key, the value and what is allowed (exit status 2).

Two kinds of scene: `kind = "couette"` (disks of the `[[species]]` placed at random between two
rings, the inner one turning; the paper's cell) and `kind = "free"` (explicit particles, no
rings: `[[particles]]` tables or a `particles_file`, and optionally fixed wall disks).

This page is generated from the declarations in `pardem/input/scene.py` by
`python run_scripts/tools/input_reference.py`.
"""

FREE = """## Free-scene particles: `[[particles]]` or `particles_file`

Free scenes only, one or the other. Each `[[particles]]` table is one particle (id = its
position in the list); `particles_file = "FILE"` reads the same columns from a `.csv` file (a
header line naming them) or an `.h5` file (one dataset per column), relative to the scene
file's folder.

| column | unit | default |
|---|---|---|
{rows}

{doc}
"""

WALLS = """## Fixed wall disks: `wall_disks_file` or `[[wall_disks]]`

Free scenes only, one or the other, optional (a boundary: docs/extending.md, "Adding a
boundary"). `wall_disks_file = "FILE.csv"` reads disks that never move, infinitely massive,
from a `.csv` file with the header `x,y,diameter` (`#` comment lines allowed), relative to the
scene file's folder; each `[[wall_disks]]` table is one such disk with the same keys (the
resolved scene holds them so). They follow the free particles in id order; no free particle
may start more than 1 % of the smaller diameter into one.

| column | unit | default |
|---|---|---|
| `x` | m | required |
| `y` | m | required |
| `diameter` | m | required |
"""


def _allowed(rule: str) -> str:
    if not rule:
        return ""
    if "|" in rule:
        return "one of " + ", ".join(f'`"{o}"`' for o in rule.split("|"))
    signs = {">=": "≥", "<=": "≤", ">": ">"}
    return ", ".join(f"{signs[op]} {part[len(op):]}" for part in rule.split()
                     for op in [next(o for o in signs if part.startswith(o))])


def _default(f: dataclasses.Field) -> str:
    if f.default is MISSING:
        return "required"
    if f.default is None:
        return '`"auto"`' if "None" in str(f.type) else "(see text)"
    if isinstance(f.default, bool):
        return f"`{str(f.default).lower()}`"
    if isinstance(f.default, str):
        return f'`"{f.default}"`'
    return f"`{f.default!r}`"


def _doc(cls: type) -> str:
    return " ".join(inspect.cleandoc(cls.__doc__ or "").split())


def _normal_laws() -> str:
    """The choices of ``[contact] normal``, from their descriptors (contact.normal.LAWS)."""
    rows = [f"| `\"{law.name}\"` | {law.summary} | "
            + (", ".join(f"`{k}`" for k in law.keys) or "–") + " | "
            + (", ".join(f"`{k}`" for k in law.required) or "–") + " | "
            + (", ".join(f"`{k}`" for k in law.history) or "–") + " |"
            for law in LAWS.values()]
    return ("### The normal laws (`normal`)\n\nEach law takes only its own parameters: a key of "
            "another law is refused, naming the law. A law that sets the tangential stiffness "
            "itself (Mindlin) refuses `k_t`. The time step, the impact-speed checks and the "
            "averaging's k'_n use the law's linear stiffness at its reference overlap "
            "(docs/extending.md).\n\n"
            "| normal | law | its parameters | required | history per contact |\n"
            "|---|---|---|---|---|\n" + "\n".join(rows) + "\n")


def _unit(key: str) -> str:
    return Contact.__dataclass_fields__[key].metadata["unit"] or "–"


def _pair_tables() -> str:
    """The ``[[contact.pair]]`` tables (pair_input.py: their keys, from [contact]'s)."""
    rings = " or ".join(f'`"{b}"`' for b in BOUNDARIES)
    return ("## `[[contact.pair]]`\n\n*optional, any number: the contact law of one pair*\n\n"
            f"{_doc(PairLaw)}\n\n| key | kind | unit | allowed |\n|---|---|---|---|\n"
            f"| `species` | list of two | – | species names, or a species and {rings} (couette);"
            " species numbers (free) |\n"
            + "\n".join(f"| `{k}` | number | {_unit(k)} | as in `[contact]` |" for k in PAIR_KEYS)
            + "\n\nNot in a pair table (one value per scene): "
            + ", ".join(f"`{k}`" for k in SCENE_KEYS)
            + ". Mixing rule, scales and how a pair's law reaches the kernels: "
              "[Parameters per pair of species](extending.md#parameters-per-pair-of-species).\n")


def render() -> str:
    parts = [INTRO]
    for name, cls, when in TABLES:
        rows = [f"| `{f.name}` | {KINDS[str(f.type)]} | {f.metadata['unit'] or '–'} | "
                f"{_default(f)} | {_allowed(f.metadata['rule']) or '–'} |"
                for f in dataclasses.fields(cls)]
        if cls is SceneInfo:  # the name defaults to the file's stem (schema.scene_from_dict)
            rows = [r.replace("| (see text) |", "| the file name without `.toml` |")
                    for r in rows]
        parts.append(f"## `{name}`\n\n*{when}*\n\n{_doc(cls)}\n\n"
                     "| key | kind | unit | default | allowed |\n|---|---|---|---|---|\n"
                     + "\n".join(rows) + "\n")
        if cls is Contact:
            parts.append(_normal_laws())
            parts.append(_pair_tables())
    optional = ("vx", "vy", "omega", "species")
    prows = "\n".join(f"| `{k}` | {u or '–'} | {'0' if k in optional else 'required'} |"
                      for k, u in _PUNITS.items())
    parts.append(FREE.format(rows=prows, doc=_doc(FreeParticles)))
    parts.append(WALLS)
    return "\n".join(parts)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if docs/input.md is stale")
    args = parser.parse_args()
    text = render()
    if args.check:
        current = PAGE.read_text() if PAGE.exists() else ""
        if current != text:
            print(f"{PAGE} is stale: run python run_scripts/tools/input_reference.py")
            return 1
        return 0
    PAGE.write_text(text)
    print(PAGE)
    return 0


if __name__ == "__main__":
    sys.exit(main())

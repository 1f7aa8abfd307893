"""The manual's input reference (``docs/input.md``) generated from the scene schema: every
table and key with its default, unit and allowed values from the declarations in
``pardem/input/scene.py``, and its meaning from ``pardem/input/key_docs.py`` (one source each;
``tests/test_manual.py`` checks that the page is current).

    python run_scripts/tools/input_reference.py            # writes docs/input.md
    python run_scripts/tools/input_reference.py --check    # exit 1 if docs/input.md is stale
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from dataclasses import MISSING
from pathlib import Path

from pardem.boundaries.wall_file import COLUMNS as WALL_DISK_COLUMNS
from pardem.contact.normal import LAWS
from pardem.contact.pairs import BOUNDARIES
from pardem.input.pair_table import PAIR_KEYS, SCENE_KEYS
from pardem.input.key_docs import KEYS
from pardem.input.key_docs import TABLES as TEXT
from pardem.input.scene import (_PUNITS, AveragingCfg, Contact, Effects, Geometry, Neighbors,
                                OutputCfg, SceneInfo, Species, TimeCfg, WarningsCfg)

PAGE = Path(__file__).resolve().parents[2] / "docs" / "input.md"
TABLES = (("scene", SceneInfo, "required"), ("geometry", Geometry, "couette scenes"),
          ("species", Species, "couette scenes: one table per species, at least one"),
          ("contact", Contact, "optional"), ("effects", Effects, "optional"),
          ("time", TimeCfg, "optional"), ("neighbors", Neighbors, "optional"),
          ("output", OutputCfg, "optional"),
          ("averaging", AveragingCfg, "optional: in-situ ring averaging of couette scenes"),
          ("warnings", WarningsCfg, "optional"))
ARRAYS = ("species",)  # tables given as [[name]], one per item
WALL_COLUMNS = {k: "m" for k in WALL_DISK_COLUMNS}  # x, y, diameter
HEAD = "| key | default | unit | allowed values | meaning |\n|---|---|---|---|---|\n"
COLUMN_HEAD = "| column | default | unit | meaning |\n|---|---|---|---|\n"
KINDS = {"float": "number", "int": "integer", "bool": "`true`, `false`", "str": "text"}

INTRO = """# Input reference

A scene is a TOML file. `pardem check SCENE.toml` prints it resolved (every default filled
in) with its time step and an estimated run time; `pardem run` stores the resolved scene with
the run (`DIR/scene.toml`). Units are SI throughout: m, kg, s, rad, N. A key that is not listed
here, a value of the wrong kind or outside what is allowed is refused with one line naming the
table, the key, the value and what is allowed (exit status 2). A key whose default is `"auto"`
may be given as `"auto"` too; its meaning says what that resolves to.

Two kinds of scene: `kind = "couette"` (disks of the `[[species]]` placed at random between two
rings, the inner one turning; the paper's cell) and `kind = "free"` (explicit particles, no
rings: `[[particles]]` tables or a `particles_file`, and optionally fixed wall disks).

This page is generated from the scene schema by `python run_scripts/tools/input_reference.py`.
"""


def _allowed(f: dataclasses.Field) -> str:
    """Kind and rule of a key as a reader writes them in TOML."""
    kind = str(f.type)
    rule = f.metadata["rule"]
    if "|" in rule:
        return ", ".join(f'`"{o}"`' for o in rule.split("|"))
    base = KINDS[kind.split(" | ")[0]]
    signs = {">=": "≥", "<=": "≤", ">": ">"}
    if rule:
        base += " " + ", ".join(f"{signs[op]} {part[len(op):]}" for part in rule.split()
                                for op in [next(o for o in signs if part.startswith(o))])
    if kind.endswith("| None"):
        base += ' or `"auto"`'
    elif kind.endswith("| bool"):
        base += " or `false`"
    return base


def _default(f: dataclasses.Field) -> str:
    if f.default is MISSING:
        return "required"
    if f.default is None:
        return '`"auto"`' if "None" in str(f.type) else "the file name without `.toml`"
    if isinstance(f.default, bool):
        return f"`{str(f.default).lower()}`"
    if isinstance(f.default, str):
        return f'`"{f.default}"`'
    return f"`{f.default!r}`"


def _normal_laws() -> str:
    """The choices of ``[contact] normal``, from their descriptors."""
    rows = [f"| `\"{law.name}\"` | {law.summary} | "
            + (", ".join(f"`{k}`" for k in law.keys) or "–") + " | "
            + (", ".join(f"`{k}`" for k in law.required) or "–") + " | "
            + (", ".join(f"`{k}`" for k in law.history) or "–") + " |"
            for law in LAWS.values()]
    return ("### The normal laws (`normal`)\n\nEach law takes only its own parameters: a key of "
            "another law is refused, naming the law. A law that sets the tangential stiffness "
            "itself (Mindlin) refuses `k_t`. The time step, the impact-speed checks and the "
            "averaging's k'_n use the law's linear stiffness at its reference overlap "
            "([Adding a contact law](extending.md)).\n\n"
            "| normal | law | its parameters | required | history per contact |\n"
            "|---|---|---|---|---|\n" + "\n".join(rows) + "\n")


def _unit(key: str) -> str:
    return Contact.__dataclass_fields__[key].metadata["unit"] or "–"


def _pair_tables() -> str:
    """The ``[[contact.pair]]`` tables: [contact]'s keys of a contact, one pair each."""
    rows = [f"| `species` | required | – | a list of two | {KEYS['contact.pair', 'species']} |"]
    rows += [f"| `{k}` | the `[contact]` value | {_unit(k)} | as in `[contact]` | "
             f"{KEYS['contact', k]} |" for k in PAIR_KEYS]
    return ("## `[[contact.pair]]`\n\n*optional, any number*\n\n"
            f"{TEXT['contact.pair']}\n\n{HEAD}" + "\n".join(rows)
            + "\n\nNot in a pair table (one value per scene): "
            + ", ".join(f"`{k}`" for k in SCENE_KEYS) + ".\n")


def _required_by(key: str) -> str:
    """"required with `hertz`" for a key that a normal law other than the default requires."""
    laws = [n for n, law in LAWS.items() if key in law.required]
    return " or ".join(f"required with `{n}`" for n in laws)


def _table(name: str, cls: type, when: str) -> str:
    rows = [f"| `{f.name}` | {name == 'contact' and _required_by(f.name) or _default(f)} | {f.metadata['unit'] or '–'} | {_allowed(f)} | "
            f"{KEYS[name, f.name]} |" for f in dataclasses.fields(cls)]
    title = f"[[{name}]]" if name in ARRAYS else f"[{name}]"
    return f"## `{title}`\n\n*{when}*\n\n{TEXT[name]}\n\n{HEAD}" + "\n".join(rows) + "\n"


def _columns(table: str, units: dict[str, str], required: tuple[str, ...]) -> str:
    return COLUMN_HEAD + "\n".join(
        f"| `{k}` | {'required' if k in required else '0'} | {u or '–'} | {KEYS[table, k]} |"
        for k, u in units.items()) + "\n"


def render() -> str:
    parts = [INTRO]
    for name, cls, when in TABLES:
        parts.append(_table(name, cls, when))
        if cls is Contact:
            parts.append(_normal_laws())
            parts.append(_pair_tables())
    parts.append("## Free-scene particles: `[[particles]]` or `particles_file`\n\n"
                 f"{TEXT['particles']}\n\n"
                 + _columns("particles", _PUNITS, ("x", "y", "diameter", "mass")))
    parts.append("## Fixed wall disks: `[[wall_disks]]` or `wall_disks_file`\n\n"
                 f"{TEXT['wall_disks']}\n\n"
                 + _columns("wall_disks", WALL_COLUMNS, tuple(WALL_COLUMNS)))
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

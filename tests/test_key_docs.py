"""The words of the input reference (pardem/input/key_docs.py): one line for every key a scene
may hold, none for a key that does not exist, and none that speaks Python instead of TOML."""

import re

from pardem.boundaries.wall_file import COLUMNS as WALL_COLUMNS
from pardem.input.key_docs import KEYS, TABLES
from pardem.input.scene import _PUNITS
from pardem.input.schema import _TABLES


def _accepted() -> set[tuple[str, str]]:
    """Every (table, key) a scene file may hold, from the validator's own tables."""
    keys = {(table, k) for table, schema in _TABLES.items() for k in schema}
    keys |= {("particles", k) for k in _PUNITS} | {("wall_disks", k) for k in WALL_COLUMNS}
    return keys | {("contact.pair", "species")}  # its other keys are [contact]'s


def test_every_key_a_scene_may_hold_has_a_meaning():
    missing = sorted(_accepted() - set(KEYS))
    assert not missing, f"add a line to pardem/input/key_docs.py KEYS for {missing}"


def test_no_meaning_describes_a_key_that_does_not_exist():
    extra = sorted(set(KEYS) - _accepted())
    assert not extra, f"key_docs.KEYS describes keys the schema does not accept: {extra}"
    assert set(TABLES) == {table for table, _ in _accepted()}


def test_the_words_are_toml_not_python():
    python = re.compile(r"\bNone\b|\bTrue\b|\bFalse\b|\.py\b|\b[a-z_]+\.[A-Z]\w+|__")
    for where, text in [*KEYS.items(), *TABLES.items()]:
        assert text.strip() and text == " ".join(text.split()), where
        assert "|" not in text, f"{where}: a '|' splits the Markdown table row"
        assert not python.search(text), f"{where}: {python.search(text)[0]!r} in {text!r}"

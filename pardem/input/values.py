"""Type and rule checks of single scene values, shared by the scene tables (``schema.py``) and
the free-particle input (``particles_input.py``): one message per problem, naming the key, the
value, what is allowed and the unit.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import MISSING, field
from typing import Any

import numpy as np

from .errors import SceneError

REQ = object()  # marks a required key
FLOAT, INT, BOOL, STR, AUTO, INT_AUTO = "float", "int", "bool", "str", "auto", "int-auto"
OFF = "off"  # a number, or false to switch off what the number sets (a warning's threshold)


def key(default: Any = MISSING, unit: str = "", rule: str = ""):
    """A scene key: its default (none: required), unit and allowed values (">0", ">=5",
    "a|b"); its kind comes from the annotation ("float | None" accepts "auto", "float | bool"
    a number or false). The checks (schema.py) read these, so a key is declared once."""
    meta = {"unit": unit, "rule": rule}
    return field(metadata=meta) if default is MISSING else field(default=default, metadata=meta)


def show(v: Any) -> str:
    """A value as the message shows it (TOML spelling for booleans)."""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        return repr(float(v))
    return repr(v)


def is_num(v: Any) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def value(label: str, key: str, v: Any, kind: str, unit: str) -> Any:
    """Type-check one value; ints become floats where floats are expected, "auto" -> None,
    false stays false where a number may be switched off."""
    u = f" ({unit})" if unit else ""
    head = f"{label} {key} = {show(v)}:"
    if kind == BOOL:
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
        raise SceneError(f"{head} expected a boolean (true or false)")
    if kind == STR:
        if isinstance(v, str):
            return v
        raise SceneError(f"{head} expected a string")
    if kind == INT:
        if isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_)):
            return int(v)
        raise SceneError(f"{head} expected an integer{u}")
    if kind in (AUTO, INT_AUTO) and isinstance(v, str) and v == "auto":
        return None
    if kind == OFF and v is False:
        return False
    if kind == INT_AUTO:
        if isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_)):
            return int(v)
        raise SceneError(f'{head} expected an integer or "auto"{u}')
    if not is_num(v):
        other = {AUTO: ' or "auto"', OFF: " or false (off)"}.get(kind, "")
        raise SceneError(f"{head} expected a number{u}{other}")
    if not math.isfinite(float(v)):
        raise SceneError(f"{head} must be finite{u}")
    return float(v)


def rule_ok(v: Any, rule: str) -> tuple[bool, str]:
    """Whether ``v`` obeys ``rule`` ("a|b|c": one of; ">x", ">=x", "<=x"; several
    space-separated bounds must all hold), and what the rule says."""
    if "|" in rule:
        opts = rule.split("|")
        return v in opts, "must be one of " + ", ".join(repr(o) for o in opts)
    for part in rule.split():
        op = next(o for o in (">=", "<=", ">") if part.startswith(o))
        bound = float(part[len(op):])
        ok = v >= bound if op == ">=" else (v <= bound if op == "<=" else v > bound)
        if not ok:
            return False, f"must be {op} {part[len(op):]}"
    return True, ""


def fail(label: str, key: str, v: Any, why: str, unit: str = "") -> SceneError:
    return SceneError(f"{label} {key} = {show(v)}: {why}" + (f" ({unit})" if unit else ""))


class Columns:
    """Base of a frozen dataclass of float64 columns named in ``COLUMNS``: stored as read-only
    arrays, compared and hashed by value (a scene is a value)."""

    COLUMNS: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for k in self.COLUMNS:
            a = np.array(getattr(self, k), dtype=np.float64)
            a.setflags(write=False)
            object.__setattr__(self, k, a)

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return all(np.array_equal(getattr(self, k), getattr(other, k)) for k in self.COLUMNS)

    def __hash__(self) -> int:
        return hash(tuple(getattr(self, k).tobytes() for k in self.COLUMNS))

"""The descriptor of a choice of the contact model's normal slot (normal.py lists the choices
and documents each field)."""

from __future__ import annotations

from typing import Callable, NamedTuple


class NormalLaw(NamedTuple):
    """A choice of the normal slot (its fields: normal.py)."""

    name: str
    code: int
    keys: tuple[str, ...]
    required: tuple[str, ...]
    history: tuple[str, ...]
    coefficients: Callable
    stiffness: Callable
    tangential: bool = False
    restitution: bool = False
    check: Callable | None = None
    summary: str = ""

"""A boundary of fixed wall disks at places a user's file gives: obstacles, a rough floor, a
container of any shape for a free scene.

Stage: input (``wall_disks_of``: the scene key and its checks) and set-up (``file_disks``).
``wall_disks_file = "FILE.csv"`` (columns x, y, diameter; relative to the scene file's folder)
or ``[[wall_disks]]`` tables with the same keys, which the resolved scene holds, so that it
stands alone. Each row is an infinitely massive disk that never moves (kind FIXED_WALL): it
needs no compiled code of its own, since wall disks that the kinematics does not place keep
their set-up place and zero velocity, and the lists, the pair loop and the exchange handle
every wall disk alike. Free scenes only: a Couette scene places its free disks at random,
blind to obstacles.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .protocol import NO_DISKS, Boundary, Glued
from ..input.errors import SceneError
from ..input.particles import csv_columns, data_file
from ..core.state import FIXED_WALL
from ..input.values import FLOAT, Columns, fail, show, value

COLUMNS = ("x", "y", "diameter")
MAX_FILE_DISKS = 1_000_000  # every rank holds every wall disk
KEY, TABLES = "wall_disks_file", "[[wall_disks]]"


@dataclass(frozen=True, eq=False)
class WallDisks(Columns):
    """Fixed wall disks, row i the i-th: read-only float64 arrays x, y (m) and diameter (m)."""

    COLUMNS = COLUMNS
    x: np.ndarray
    y: np.ndarray
    diameter: np.ndarray

    def rows(self) -> list[dict[str, float]]:
        """The ``[[wall_disks]]`` tables of the resolved scene."""
        return [dict(zip(COLUMNS, r)) for r in zip(*(getattr(self, k).tolist() for k in COLUMNS))]


def wall_disks_of(d: dict[str, Any], kind: str, particles, base_dir: Path) -> WallDisks | None:
    """The fixed wall disks a scene dict asks for (None: none), checked: a file or tables,
    not both; free scenes only; finite places, positive diameters; no free disk starting
    more than 1 % of the smaller diameter into one."""
    if KEY not in d and "wall_disks" not in d:
        return None
    if KEY in d and "wall_disks" in d:
        raise SceneError(f"{TABLES} and {KEY}: give one or the other, not both")
    where = f"{KEY} = {d[KEY]!r}" if KEY in d else TABLES
    if kind != "free":
        raise SceneError(f"{where}: allowed in free scenes only (a couette scene places its "
                         "free disks at random, blind to obstacles)")
    cols = _from_file(d[KEY], base_dir) if KEY in d else _from_tables(d["wall_disks"])
    n = cols["x"].size
    if n > MAX_FILE_DISKS:
        raise SceneError(f"{where}: {n} wall disks, more than {MAX_FILE_DISKS} (every rank "
                         "holds and reads them all)")
    for k in COLUMNS:
        bad = ~np.isfinite(cols[k]) | ((cols[k] <= 0) if k == "diameter" else False)
        if bad.any():
            i = int(np.argmax(bad))
            raise fail(f"{where} row #{i}", k, cols[k][i],
                       "must be > 0" if k == "diameter" else "must be finite", "m")
    disks = WallDisks(**cols)
    _check_clear(disks, particles, where)
    return disks


def _from_file(name: Any, base_dir: Path) -> dict[str, np.ndarray]:
    path = data_file(name, base_dir, KEY, ".csv")
    label = f"{KEY} = {name!r}"
    if path.suffix.lower() != ".csv":
        raise SceneError(f"{label}: expected a .csv file (a header line x, y, diameter)")
    cols = csv_columns(path, label, "wall-disk")
    for k in cols:
        if k not in COLUMNS:
            raise SceneError(f"{label}: unknown column {k!r}; allowed: {', '.join(COLUMNS)}")
    for k in COLUMNS:
        if k not in cols:
            raise SceneError(f"{label}: required column {k!r} missing")
    return cols


def _from_tables(rows: Any) -> dict[str, np.ndarray]:
    if not isinstance(rows, list) or not rows:
        raise SceneError(f"{TABLES}: expected a non-empty array of tables")
    for i, r in enumerate(rows):
        if not isinstance(r, dict):
            raise SceneError(f"{TABLES} #{i}: expected a table, got {show(r)}")
        for k in r.keys() - set(COLUMNS):
            raise SceneError(f"{TABLES} #{i} unknown key {k!r}; allowed: {', '.join(COLUMNS)}")
        for k in COLUMNS:
            if k not in r:
                raise SceneError(f"{TABLES} #{i} {k}: missing (required)")
            value(f"{TABLES} #{i}", k, r[k], FLOAT, "m")
    return {k: np.array([r[k] for r in rows], dtype=np.float64) for k in COLUMNS}


def _check_clear(disks: WallDisks, particles, where: str) -> None:
    """No free disk starts overlapping a wall disk by more than 1 % of the smaller diameter
    (the same tolerance as between free disks): its first step would fling it out."""
    if particles is None:
        return
    for i in range(disks.x.size):
        dist = np.hypot(particles.x - disks.x[i], particles.y - disks.y[i])
        d = np.minimum(particles.diameter, disks.diameter[i])
        over = 0.5 * (particles.diameter + disks.diameter[i]) - dist - 0.01 * d
        if (over > 0).any():
            j = int(np.argmax(over))
            overlap = over[j] + 0.01 * d[j]
            raise SceneError(f"{where} row #{i} and [[particles]] #{j} overlap by "
                             f"{overlap:.3g} m = {100 * overlap / d[j]:.3g}% of the smaller "
                             "diameter (at most 1% allowed)")


def file_disks(scene) -> Glued:
    """The fixed wall disks of a scene at t = 0 (they never move)."""
    w = scene.wall_disks
    if w is None:
        return NO_DISKS
    n = w.x.size
    return Glued(np.column_stack([w.x, w.y]), 0.5 * w.diameter, np.full(n, FIXED_WALL, np.int8),
                 np.zeros(n))


WALL_FILE = Boundary(
    "wall-disk file", (KEY, TABLES), (FIXED_WALL,), file_disks, moves=False, surface=False,
    present=lambda scene: scene.wall_disks is not None,
    summary="fixed wall disks at the places a file gives (free scenes)")

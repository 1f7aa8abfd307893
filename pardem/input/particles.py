"""Free-scene particles from ``[[particles]]`` tables or a ``particles_file`` (.csv or .h5), and
their checks (finite values, positive sizes, no coincident or deeply overlapping disks).

Stage: input (called by ``schema.scene_from_dict``). Errors name the row and column.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from .scene import _PCOLS, _PUNITS, MAX_SPECIES, FreeParticles, SceneError
from .values import FLOAT, REQ, fail, show, value

_PDEFAULT = {"vx": 0.0, "vy": 0.0, "omega": 0.0, "species": 0.0}

def particles_from_tables(rows: list[Any]) -> dict[str, np.ndarray]:
    """Columns from ``[[particles]]`` tables; vectorised type checks keep 1e5 rows fast."""
    for i, r in enumerate(rows):
        if not isinstance(r, dict):
            raise SceneError(f"[[particles]] #{i}: expected a table, got {show(r)}")
        extra = r.keys() - _PUNITS.keys()
        if extra:
            raise SceneError(f"[[particles]] #{i} unknown key {min(extra)!r}; "
                             f"allowed: {', '.join(_PCOLS)}")
    cols = {}
    for k in _PCOLS:
        dflt = _PDEFAULT.get(k, REQ)
        vals = [r.get(k, dflt) for r in rows]
        if {type(v) for v in vals} <= {float, int, np.float64}:
            cols[k] = np.array(vals, dtype=np.float64)
            continue
        for i, v in enumerate(vals):  # slow path only to name the first bad row
            if v is REQ:
                raise SceneError(f"[[particles]] #{i} {k}: missing (required)")
            value(f"[[particles]] #{i}", k, v, FLOAT, _PUNITS[k])
        cols[k] = np.array(vals, dtype=np.float64)
    return cols


def data_file(name: Any, base_dir: Path, key: str, kinds: str) -> Path:
    """The file a scene key names (relative to the scene file's folder), or the SceneError that
    names ``key`` and why it cannot be read; ``kinds``: what it may be (".csv or .h5")."""
    if not isinstance(name, str):
        raise SceneError(f"{key} = {show(name)}: expected a file name ({kinds})")
    path = base_dir / name
    label = f"{key} = {name!r}"
    if not path.exists():
        raise SceneError(f"{label}: no such file {str(path)!r}")
    if path.is_dir():
        raise SceneError(f"{label}: {str(path)!r} is a folder; expected a {kinds} file")
    if not path.is_file():
        raise SceneError(f"{label}: {str(path)!r} is not a regular file (a device or a pipe); "
                         f"expected a {kinds} file")
    return path


def csv_columns(path: Path, label: str, rows: str) -> dict[str, np.ndarray]:
    """The columns of a CSV file by header name; a byte-order mark (spreadsheet exports) and
    '#' comment lines are allowed. ``rows``: what a row is (errors name it)."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as e:
        raise SceneError(f"{label}: not a UTF-8 text file ({e.reason} at byte "
                         f"{e.start})") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 2:
        raise SceneError(f"{label}: expected a header row and at least one {rows} row")
    header = [h.strip() for h in lines[0].split(",")]
    twice = sorted({h for h in header if header.count(h) > 1})
    if twice:
        raise SceneError(f"{label}: column {twice[0]!r} appears more than once in the header")
    try:
        data = np.loadtxt(lines[1:], delimiter=",", dtype=np.float64, ndmin=2)
    except ValueError as e:
        raise SceneError(f"{label}: unreadable CSV data: {e}") from None
    if data.shape[1] != len(header):
        raise SceneError(f"{label}: {data.shape[1]} columns but {len(header)} header names")
    return {h: data[:, j] for j, h in enumerate(header)}


def particles_from_file(name: Any, base_dir: Path) -> dict[str, np.ndarray]:
    path = data_file(name, base_dir, "particles_file", ".csv or .h5")
    label = f"particles_file = {name!r}"
    cols: dict[str, np.ndarray] = {}
    if path.suffix.lower() == ".csv":
        cols = csv_columns(path, label, "particle")
    elif path.suffix.lower() in (".h5", ".hdf5"):
        import h5py  # only free scenes with HDF5 input pay for the import

        try:
            f = h5py.File(path, "r")
        except OSError as e:
            raise SceneError(f"{label}: not a readable HDF5 file ({e})") from None
        with f:
            for k, ds in f.items():
                if not isinstance(ds, h5py.Dataset) or ds.ndim != 1:
                    raise SceneError(f"{label}: {k!r} must be a 1-D dataset at the file root")
                if ds.dtype.kind not in "iuf":
                    raise SceneError(f"{label}: {k!r} holds {ds.dtype} values; expected numbers")
                cols[k] = np.asarray(ds[()], dtype=np.float64)
    else:
        raise SceneError(f"{label}: expected a .csv or .h5 file")
    for k in cols:
        if k not in _PUNITS:
            raise SceneError(f"{label}: unknown column {k!r}; allowed: {', '.join(_PCOLS)}")
    lengths = {len(c) for c in cols.values()}
    if len(lengths) > 1:
        raise SceneError(f"{label}: columns have different lengths {sorted(lengths)}")
    n = lengths.pop() if lengths else 0
    for k in _PCOLS:
        if k not in cols:
            if k not in _PDEFAULT:
                raise SceneError(f"{label}: required column {k!r} missing")
            cols[k] = np.full(n, _PDEFAULT[k])
    return cols


def check_particles(cols: dict[str, np.ndarray], where: str) -> FreeParticles:
    """Finite values, positive diameter and mass, N >= 1, no coincident or deep overlaps."""
    n = len(cols["x"])
    if n == 0:
        raise SceneError(f"{where}: a free scene needs at least one particle")
    for k in _PCOLS:
        bad = ~np.isfinite(cols[k])
        if k in ("diameter", "mass"):
            bad |= ~(cols[k] > 0)
        if k == "species":
            bad |= ~((cols[k] >= 0) & (cols[k] < MAX_SPECIES) & (cols[k] == np.round(cols[k])))
        if bad.any():
            i = int(np.argmax(bad))
            why = ("must be > 0" if k in ("diameter", "mass") else
                   f"must be an integer 0 .. {MAX_SPECIES - 1}" if k == "species" else
                   "must be finite")
            raise fail(f"{where} #{i}", k, cols[k][i], why, _PUNITS[k])
    x, y, d = cols["x"], cols["y"], cols["diameter"]
    pair = _worst_pair(x, y, d)
    if pair is not None:
        i, j = pair
        if x[i] == x[j] and y[i] == y[j]:
            raise SceneError(f"{where} #{i} and #{j}: identical positions ({show(x[i])}, "
                             f"{show(y[i])})")
        ov = 0.5 * (d[i] + d[j]) - math.hypot(x[i] - x[j], y[i] - y[j])
        raise SceneError(f"{where} #{i} and #{j} overlap by {ov:.3g} m = "
                         f"{100 * ov / min(d[i], d[j]):.3g}% of the smaller diameter "
                         "(at most 1% allowed)")
    return FreeParticles(**{k: cols[k] for k in _PCOLS})


FEW_LARGE = 64
"""Disks over 4 x the median diameter, up to this many, are checked against every other disk
instead of setting the cell size (one 1 m disk among 40,000 of 1 mm: 42 s in one cell)."""


def _worst_pair(x: np.ndarray, y: np.ndarray, d: np.ndarray) -> tuple[int, int] | None:
    """An (i, j), i < j, overlapping by > 1% of the smaller diameter, or None. Cell grid of side
    max(d), so only the 3x3 neighbourhood can overlap: O(N log N) while sizes are comparable;
    a few much larger disks are compared with every disk (O(N) each) and left out of the grid."""
    large = np.flatnonzero(d > 4.0 * np.median(d))
    if 0 < large.size <= FEW_LARGE and large.size < d.size:
        for i in large.tolist():
            dist = np.hypot(x - x[i], y - y[i])
            hit = (0.5 * (d + d[i]) - dist > 0.01 * np.minimum(d, d[i])) | (dist == 0)
            hit[i] = False
            if hit.any():
                j = int(np.argmax(hit))
                return min(i, j), max(i, j)
        rest = np.setdiff1d(np.arange(d.size), large)
        pair = _worst_pair_grid(x[rest], y[rest], d[rest])
        return None if pair is None else (int(rest[pair[0]]), int(rest[pair[1]]))
    return _worst_pair_grid(x, y, d)


def _worst_pair_grid(x: np.ndarray, y: np.ndarray, d: np.ndarray) -> tuple[int, int] | None:
    n = x.size
    if n < 2:
        return None
    h = float(d.max())
    # the spread is checked in floating point, before a cast to int64 could overflow
    if max(x.max() - x.min(), y.max() - y.min()) / h >= 2**30 - 2:
        raise SceneError("[[particles]]: positions spread over more than 1e9 diameters")
    cx = np.floor((x - x.min()) / h).astype(np.int64)
    cy = np.floor((y - y.min()) / h).astype(np.int64) + 1  # +1: offset dcy = -1 stays >= 0
    ny = int(cy.max()) + 2
    key = cx * ny + cy
    order = np.argsort(key, kind="stable")
    ks = key[order]
    rank = np.empty(n, np.int64)
    rank[order] = np.arange(n)
    for dcx, dcy in ((0, 0), (1, -1), (1, 0), (1, 1), (0, 1)):  # half stencil: each pair once
        nk = key + dcx * ny + dcy
        start = rank + 1 if dcx == dcy == 0 else np.searchsorted(ks, nk, "left")
        stop = np.searchsorted(ks, nk, "right")
        m = 0
        while True:
            pos = start + m
            live = np.nonzero(pos < stop)[0]
            if live.size == 0:
                break
            j = order[pos[live]]
            dist = np.hypot(x[live] - x[j], y[live] - y[j])
            ov = 0.5 * (d[live] + d[j]) - dist
            hit = (ov > 0.01 * np.minimum(d[live], d[j])) | (dist == 0)
            if hit.any():  # stop at the first hits: a heap of coincident disks stays cheap
                return min((min(a, b), max(a, b))
                           for a, b in zip(live[hit].tolist(), j[hit].tolist()))
            m += 1
    return None


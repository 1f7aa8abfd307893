"""Hexagonal (bond-orientational) order of the small disks, psi_6, from positions.

Stage: averaging (flow regime). For a disk p with neighbours q at bond angles theta_pq,
psi_6(p) = |(1/N_p) Sum_q exp(6 i theta_pq)|: 1 in a perfect triangular lattice, 0 in a square
one, about 1/sqrt(N_p) for random bonds. Neighbours are the other disks of the same species
whose centres lie within ``reach`` diameters (default 1.35: between the first and second
neighbour shells of a dense packing of equal disks, at the first minimum of g(r)); a disk
with no neighbour gets NaN. This needs neighbours beyond the contact range, which a rank does
not hold in situ, so psi_6 is computed from snapshots (every particle), not from ring sums.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from pardem.sampling import JIT

REACH = 1.35  # neighbour distance in diameters of the species


@nb.njit(**JIT)
def _psi6(x, cut, cell_of, order, first, nx, ny):
    n = x.shape[0]
    out = np.full(n, np.nan)
    cut2 = cut * cut
    for p in range(n):
        cx, cy = cell_of[p] % nx, cell_of[p] // nx
        re, im, count = 0.0, 0.0, 0
        for gy in range(max(cy - 1, 0), min(cy + 2, ny)):
            for gx in range(max(cx - 1, 0), min(cx + 2, nx)):
                c = gy * nx + gx
                for k in range(first[c], first[c + 1]):
                    q = order[k]
                    if q == p:
                        continue
                    dx, dy = x[q, 0] - x[p, 0], x[q, 1] - x[p, 1]
                    if dx * dx + dy * dy < cut2:
                        t = 6.0 * math.atan2(dy, dx)
                        re += math.cos(t)
                        im += math.sin(t)
                        count += 1
        if count:
            out[p] = math.hypot(re, im) / count
    return out


def psi6(x: np.ndarray, diameter: float, reach: float = REACH) -> np.ndarray:
    """|psi_6| [n] of disks at x [n,2] (m) of one species of ``diameter`` (m)."""
    x = np.ascontiguousarray(x, dtype=float)
    if not len(x):
        return np.zeros(0)
    cut = reach * diameter
    lo = x.min(axis=0)
    nx, ny = (int((x[:, k].max() - lo[k]) / cut) + 1 for k in (0, 1))
    cell = ((x[:, 1] - lo[1]) // cut).astype(np.int64) * nx + ((x[:, 0] - lo[0]) // cut).astype(
        np.int64)
    order = np.argsort(cell, kind="stable")
    first = np.searchsorted(cell[order], np.arange(nx * ny + 1))
    return _psi6(x, cut, cell, order, first, nx, ny)


def psi6_profile(snapshots, r_in: float, d_ref: float, edges: np.ndarray) -> np.ndarray:
    """Mean psi_6 of the small disks (the species of the smallest free diameter) by the r~ =
    (r - r_in)/d_ref of their centres in the bins ``edges`` [k+1], over the snapshots (dicts
    of pardem.read_snapshots); NaN in a bin without disks."""
    total, count = np.zeros(len(edges) - 1), np.zeros(len(edges) - 1)
    for snap in snapshots:
        free = snap["kind"] == 0
        d = 2.0 * snap["radius"]
        small = free & np.isclose(d, d[free].min())
        x = snap["position"][small]
        value = psi6(x, float(d[small][0]))
        r = (np.hypot(x[:, 0], x[:, 1]) - r_in) / d_ref
        ok = np.isfinite(value)
        total += np.histogram(r[ok], edges, weights=value[ok])[0]
        count += np.histogram(r[ok], edges)[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / count

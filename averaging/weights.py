"""Ring weights: the fraction of a disk's area that lies in each ring about the cell axis.

Stage: averaging. Rings k = 0..n-1 span [r0 + k dr, r0 + (k+1) dr). A disk of radius a whose
centre is at distance rho from the axis gets weight w_k = (A(r_{k+1}) - A(r_k)) / (pi a^2),
where A(R) is the disk's area inside radius R. Two choices of A:

- ``slice`` (the paper's): the circles r = R are replaced by straight lines at the disk, so
  A(R) is the area of the disk on the near side of a chord at signed distance s = R - rho
  from its centre: A = a^2 acos(-s/a) + s sqrt(a^2 - s^2). Error O(a/rho).
- ``exact``: A(R) is the area of the disk inside the circle of radius R (a lens).

Both telescope: the weights of one disk sum to 1 exactly when the rings cover it. Area below
r0 is given to ring 0 and area beyond the last ring to ring n-1, so the sum is always 1 (a
particle pressed into a ring surface reaches a little past it). Near a tangent line or circle
the formulas lose digits (acos near +-1: A(R) came out 1e-10 above pi a^2 for a rim exactly on
a ring edge), so the cumulative area is kept within [0, pi a^2] and non-decreasing: no weight
is ever negative, and the sum still telescopes to 1.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

SLICE, EXACT = 0, 1
WEIGHTINGS = {"slice": SLICE, "exact": EXACT}


@nb.njit(cache=True, error_model="numpy")
def inside_area(radius_r, rho, a, exact):
    """Area (m^2) of the disk (centre at distance rho, radius a) inside radius R."""
    if exact:
        if radius_r <= rho - a or radius_r <= 0.0:
            return 0.0
        if radius_r >= rho + a:
            return math.pi * a * a
        if rho + radius_r <= a:  # the circle of radius R lies inside the disk
            return math.pi * radius_r * radius_r
        c1 = (rho * rho + radius_r * radius_r - a * a) / (2.0 * rho * radius_r)
        c2 = (rho * rho + a * a - radius_r * radius_r) / (2.0 * rho * a)
        c1 = min(max(c1, -1.0), 1.0)
        c2 = min(max(c2, -1.0), 1.0)
        k = (-rho + radius_r + a) * (rho + radius_r - a) * (rho - radius_r + a) * \
            (rho + radius_r + a)
        return (radius_r * radius_r * math.acos(c1) + a * a * math.acos(c2)
                - 0.5 * math.sqrt(max(k, 0.0)))
    s = radius_r - rho
    if s <= -a:
        return 0.0
    if s >= a:
        return math.pi * a * a
    return a * a * math.acos(-s / a) + s * math.sqrt(a * a - s * s)


@nb.njit(cache=True, error_model="numpy")
def ring_weights(rho, a, r0, dr, n_rings, exact, rings, weights):
    """Fill rings[:m], weights[:m] with the rings the disk overlaps and its weights; return m.
    ``rings``/``weights`` must hold at least 2 a / dr + 2 entries."""
    k_lo = min(max(int(math.floor((rho - a - r0) / dr)), 0), n_rings - 1)
    k_hi = min(max(int(math.floor((rho + a - r0) / dr)), 0), n_rings - 1)
    full = math.pi * a * a
    below = 0.0  # area inside the ring's inner edge (ring 0 also takes what lies below r0)
    m = 0
    for k in range(k_lo, k_hi + 1):
        outer = full if k == n_rings - 1 else inside_area(r0 + (k + 1) * dr, rho, a, exact)
        outer = min(max(outer, below), full)
        rings[m] = k
        weights[m] = (outer - below) / full
        below = outer
        m += 1
    return m


def weights_table(rho: np.ndarray, a: np.ndarray, r0: float, dr: float, n_rings: int,
                  weighting: str) -> np.ndarray:
    """Dense weights [n_particles, n_rings] (tests and small cases)."""
    out = np.zeros((rho.size, n_rings))
    cap = int(2 * a.max() / dr) + 3
    rings, w = np.zeros(cap, np.int64), np.zeros(cap)
    for p in range(rho.size):
        m = ring_weights(rho[p], a[p], r0, dr, n_rings, WEIGHTINGS[weighting] == EXACT, rings, w)
        out[p, rings[:m]] = w[:m]
    return out

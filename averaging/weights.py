"""Ring weights: the share of a disk that each ring about the cell axis receives.

Stage: averaging. Rings k = 0..n-1 span [r0 + k dr, r0 + (k+1) dr). A disk of radius a whose
centre is at distance rho from the axis gets weight w_k = W(r_{k+1}) - W(r_k), where W(R) is
the share of the disk counted inside radius R. Four choices of W:

- ``slice`` (the paper's): the disk's area fraction on the near side of a straight chord at
  signed distance s = R - rho from its centre (the circle r = R replaced by a line at the
  disk): W = (a^2 acos(-s/a) + s sqrt(a^2 - s^2)) / (pi a^2). Error O(a/rho).
- ``exact``: the area fraction of the disk inside the circle of radius R (a lens).
- ``centre``: the whole disk counts where its centre is: W = 1 if rho < R else 0.
- ``gaussian``: coarse graining with a normal kernel in r of width sigma = a/2 (the radial
  spread of the disk's own area, which has variance a^2/4), as in MercuryCG:
  W = Phi((R - rho)/sigma), cut at 4 sigma.

Both telescope: the weights of one disk sum to 1 exactly when the rings cover it. Area below
r0 is given to ring 0 and area beyond the last ring to ring n-1, so the sum is always 1 (a
particle pressed into a ring surface reaches a little past it), and the last ring a disk
reaches takes whatever share is left, so rounding can never lose weight. Near a tangent line or
circle the formulas lose digits (acos near +-1: A(R) came out 1e-10 above pi a^2 for a rim
exactly on a ring edge), so the cumulative area is kept within [0, pi a^2] and non-decreasing:
no weight is ever negative, and the sum still telescopes to 1.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from pardem.sampling import JIT

SLICE, EXACT, CENTRE, GAUSSIAN = 0, 1, 2, 3
WEIGHTINGS = {"slice": SLICE, "exact": EXACT, "centre": CENTRE, "gaussian": GAUSSIAN}
GAUSS_CUT = 4.0  # kernel cut-off in units of sigma = a/2


@nb.njit(**JIT)
def extent(a, kind):
    """How far (m) from its centre a disk of radius a reaches with this weighting."""
    if kind == CENTRE:
        return 0.0
    if kind == GAUSSIAN:
        return GAUSS_CUT * 0.5 * a
    return a


@nb.njit(**JIT)
def inside_share(radius_r, rho, a, kind):
    """W(R): the share (0..1) of the disk counted inside radius R."""
    if kind == CENTRE:
        return 1.0 if rho < radius_r else 0.0
    if kind == GAUSSIAN:
        z = (radius_r - rho) / (0.5 * a)
        if z <= -GAUSS_CUT:
            return 0.0
        if z >= GAUSS_CUT:
            return 1.0
        return 0.5 * math.erfc(-z / math.sqrt(2.0))
    return inside_area(radius_r, rho, a, kind == EXACT) / (math.pi * a * a)


@nb.njit(**JIT)
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


@nb.njit(**JIT)
def ring_weights(rho, a, r0, dr, n_rings, kind, rings, weights):
    """Fill rings[:m], weights[:m] with the rings the disk reaches and its weights; return m.
    ``rings``/``weights`` must hold at least 2 extent(a, kind) / dr + 2 entries."""
    reach = extent(a, kind)
    k_lo = min(max(int(math.floor((rho - reach - r0) / dr)), 0), n_rings - 1)
    k_hi = min(max(int(math.floor((rho + reach - r0) / dr)), 0), n_rings - 1)
    below = 0.0  # share inside the ring's inner edge (ring 0 also takes what lies below r0)
    m = 0
    for k in range(k_lo, k_hi + 1):
        # the last ring reached takes the rest: the ring index and the share are computed in
        # different roundings, and a centre on a ring edge must not lose its weight
        outer = 1.0 if k == k_hi else inside_share(r0 + (k + 1) * dr, rho, a, kind)
        outer = min(max(outer, below), 1.0)
        rings[m] = k
        weights[m] = outer - below
        below = outer
        m += 1
    return m


def weights_table(rho: np.ndarray, a: np.ndarray, r0: float, dr: float, n_rings: int,
                  weighting: str) -> np.ndarray:
    """Dense weights [n_particles, n_rings] (tests and small cases)."""
    out = np.zeros((rho.size, n_rings))
    kind = WEIGHTINGS[weighting]
    cap = int(2 * extent(a.max(), kind) / dr) + 3
    rings, w = np.zeros(cap, np.int64), np.zeros(cap)
    for p in range(rho.size):
        m = ring_weights(rho[p], a[p], r0, dr, n_rings, kind, rings, w)
        out[p, rings[:m]] = w[:m]
    return out

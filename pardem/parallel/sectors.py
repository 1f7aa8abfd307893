"""Angular sectors of the annulus: which rank owns a point, which ranks need it as a ghost, and
where to cut so that every rank holds about the same number of free particles.

Stage: decomposition (geometry only; no MPI here). A sector is the wedge between two rays from
the cell axis, ``edges[r] <= angle < edges[r + 1]`` (rad), with ``edges[P] = edges[0] + 2 pi``.
A point outside wedge r is at distance min(distance to either boundary ray) from it; a rank
needs every particle within the ghost width of its wedge. This works for any sector width,
including a wedge wider than pi (2 ranks) and an empty one. A future radial x angular cut only
has to supply ``owners``, ``edge_vectors`` (its geometry as an array) and ``edge_distance`` for
its cells; the exchange (``exchange.py``) uses nothing else of the shape.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from ..jit import JIT

TWO_PI = 2.0 * math.pi


class Sectors(NamedTuple):
    """``edges`` [P+1] increasing angles (rad) of the sector boundaries."""

    edges: np.ndarray

    @property
    def count(self) -> int:
        return self.edges.size - 1

    def owner(self, x: np.ndarray, guess: int = 0) -> np.ndarray:
        """Rank owning each point of x [n,2] (m). ``guess``: the rank most points are expected
        in (tested first, without an arc tangent)."""
        if self.count == 1:
            return np.zeros(x.shape[0], np.int64)
        return owners(x, self.edges, guess)

    def distance(self, x: np.ndarray, rank: int) -> np.ndarray:
        """Distance (m) of points x [n,2] outside sector ``rank`` from that sector."""
        return _distance(x, self.edges, rank)


# Compiled: called at every exchange, where numpy's per-call overhead dominated.
@nb.njit(**JIT)
def owners(x, edges, guess):
    """Rank owning each point of x [n,2] (``Sectors.owner``)."""
    p = edges.size - 1
    # wedge ``guess`` by the sides of its two rays; a wedge wider than pi is tested as "not in
    # the complementary wedge", which is narrower than pi
    c0, s0 = math.cos(edges[guess]), math.sin(edges[guess])
    c1, s1 = math.cos(edges[guess + 1]), math.sin(edges[guess + 1])
    wide = edges[guess + 1] - edges[guess] > math.pi
    out = np.empty(x.shape[0], np.int64)
    for k in range(x.shape[0]):
        px, py = x[k, 0], x[k, 1]
        if wide:
            inside = not (c1 * py - s1 * px >= 0.0 and px * s0 - py * c0 > 0.0)
        else:
            inside = c0 * py - s0 * px >= 0.0 and px * s1 - py * c1 > 0.0
        if inside:
            out[k] = guess
            continue
        a = (math.atan2(py, px) - edges[0]) % TWO_PI
        r = 0
        while r < p - 1 and edges[r + 1] - edges[0] <= a:
            r += 1
        out[k] = r
    return out


@nb.njit(**JIT)
def near(x, edges, rank, margin):
    """Mask of the points x [n,2] inside sector ``rank`` or within ``margin`` (m) of it."""
    inside = owners(x, edges, rank) == rank
    e = edge_vectors(edges)
    out = np.empty(x.shape[0], np.bool_)
    for k in range(x.shape[0]):
        out[k] = inside[k] or edge_distance(x[k, 0], x[k, 1], e, rank) < margin
    return out


@nb.njit(**JIT)
def _distance(x, edges, rank):
    out = np.empty(x.shape[0])
    e = edge_vectors(edges)
    for k in range(x.shape[0]):
        out[k] = edge_distance(x[k, 0], x[k, 1], e, rank)
    return out


@nb.njit(**JIT)
def edge_vectors(edges):
    """Unit vectors of the sector edge rays, [P+1, 2] (for ``edge_distance``)."""
    e = np.empty((edges.size, 2))
    for k in range(edges.size):
        e[k, 0] = math.cos(edges[k])
        e[k, 1] = math.sin(edges[k])
    return e


@nb.njit(**JIT)
def edge_distance(px, py, e, rank):
    """Distance (m) of the point (px, py) from the edge rays of sector ``rank`` (e: edge
    vectors): from outside the sector, its distance from the sector."""
    return min(_ray_distance(px, py, e[rank, 0], e[rank, 1]),
               _ray_distance(px, py, e[rank + 1, 0], e[rank + 1, 1]))


@nb.njit(**JIT)
def _ray_distance(px, py, ex, ey):
    """Distance of the point (px, py) from the ray from the origin along (ex, ey)."""
    if px * ex + py * ey > 0.0:
        return abs(px * ey - py * ex)
    return math.hypot(px, py)


def single() -> Sectors:
    return Sectors(np.array([-math.pi, math.pi]))


def balanced(hist: np.ndarray, ranks: int) -> Sectors:
    """Sectors with about equal counts, cut at bin edges of an angular histogram of the free
    particles (``hist`` [B]: counts in B equal bins over [-pi, pi))."""
    if ranks == 1:
        return single()
    bins = hist.size
    cum = np.concatenate([[0], np.cumsum(hist)])
    total = cum[-1]
    # The first cut sits at the emptiest bin edge, so that the wrap-around is cheap to cut.
    start = int(np.argmin(hist))
    cum = np.concatenate([cum[start:-1] - cum[start], cum[:start + 1] + total - cum[start]])
    targets = total * np.arange(1, ranks) / ranks
    cuts = np.searchsorted(cum, targets)
    # Every wedge keeps at least one bin (it may hold no particle, which is allowed).
    for k in range(ranks - 1):
        low = cuts[k - 1] + 1 if k else 1
        cuts[k] = min(max(cuts[k], low), bins - ranks + 1 + k)
    edges = -math.pi + TWO_PI * (start + np.concatenate([[0], cuts, [bins]])) / bins
    return Sectors(edges)


def angle_histogram(x: np.ndarray, bins: int) -> np.ndarray:
    a = np.arctan2(x[:, 1], x[:, 0])
    k = np.clip(((a + math.pi) / TWO_PI * bins).astype(np.int64), 0, bins - 1)
    return np.bincount(k, minlength=bins).astype(np.int64)


def imbalance(counts: np.ndarray) -> float:
    """Largest count over the mean, minus 1."""
    mean = counts.mean()
    return float(counts.max() / mean - 1.0) if mean > 0 else 0.0


@nb.njit(**JIT)
def largest_move(x, x0):
    """The largest distance (m) between the rows of x and x0 ([n, 2] each, same order)."""
    d2 = 0.0
    for k in range(x.shape[0]):
        dx = x[k, 0] - x0[k, 0]
        dy = x[k, 1] - x0[k, 1]
        d2 = max(d2, dx * dx + dy * dy)
    return math.sqrt(d2)

"""How the annulus is cut among the ranks: R rings of A angular sectors each (P = R x A; one
ring: plain sectors), which rank owns a point, how far a point lies from a rank's domain, and
where to cut so that every rank holds about as many free particles.

Stage: decomposition (geometry only; no MPI here). Domain d = b A + s is the polar rectangle
``radii[b] <= r < radii[b + 1]``, ``edges[b, s] <= angle < edges[b, s + 1]`` (m, rad), with
``radii[0] = 0``, ``radii[R] = inf`` and ``edges[b, A] = edges[b, 0] + 2 pi``. A rank needs every
particle within the ghost width of its domain, by the exact distance from a point outside the
domain to it (``edge_distance``); this holds for any domain, including a wedge wider than pi, a
whole ring (A = 1) and an empty one. The exchange (``exchange.py``) sees the cut only through
``owners``, ``domain_geometry`` and ``edge_distance`` (and ``near``, built on them).

Why rings: a sector has two edges as long as the gap, so its ghosts stay constant as P grows;
rings of sectors have four shorter edges, and their ghosts fall like 1/sqrt(P).
``parallel.choice`` picks the cut with the fewest ghosts on the particles' positions.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.jit import JIT

TWO_PI = 2.0 * math.pi


class Cut(NamedTuple):
    """``radii`` [R+1] (m, 0 ... inf) ring boundaries; ``edges`` [R, A+1] increasing angles
    (rad) of the sector boundaries in each ring."""

    radii: np.ndarray
    edges: np.ndarray

    @property
    def count(self) -> int:
        return self.edges.shape[0] * (self.edges.shape[1] - 1)

    @property
    def rings(self) -> int:
        return self.edges.shape[0]

    def owner(self, x: np.ndarray, guess: int = 0) -> np.ndarray:
        """Rank owning each point of x [n,2] (m). ``guess``: the rank most points are expected
        in (tested first, without an arc tangent)."""
        if self.count == 1:
            return np.zeros(x.shape[0], np.int64)
        return owners(x, self.radii, self.edges, guess)

    def distance(self, x: np.ndarray, rank: int) -> np.ndarray:
        """Distance (m) of points x [n,2] outside domain ``rank`` from that domain."""
        return _distance(x, domain_geometry(self.radii, self.edges), rank)

    def describe(self) -> str:
        a = self.edges.shape[1] - 1
        if self.rings == 1:
            deg = np.degrees(np.diff(self.edges[0]))
            return f"sectors {', '.join(f'{d:.1f}' for d in deg)} deg"
        mm = ", ".join(f"{r * 1e3:.1f}" for r in self.radii[1:-1])
        return f"{self.rings} rings x {a} sectors (rings cut at r = {mm} mm)"


def sectors(edges: np.ndarray) -> Cut:
    """One ring of sectors with the edges [P+1] (rad)."""
    return Cut(np.array([0.0, math.inf]), np.asarray(edges, np.float64)[None, :].copy())


def single() -> Cut:
    return sectors(np.array([-math.pi, math.pi]))


@nb.njit(**JIT)
def _in_wedge(px, py, c0, s0, c1, s1, wide):
    """Whether (px, py) lies in the wedge from the ray (c0, s0) to the ray (c1, s1),
    counterclockwise, first ray included; a wedge wider than pi (``wide``) is tested as "not in
    the complementary wedge", which is narrower than pi."""
    if wide:
        return not (c1 * py - s1 * px >= 0.0 and px * s0 - py * c0 > 0.0)
    return c0 * py - s0 * px >= 0.0 and px * s1 - py * c1 > 0.0


# Compiled: called at every exchange, where numpy's per-call overhead dominated.
@nb.njit(**JIT)
def owners(x, radii, edges, guess):
    """Rank owning each point of x [n,2] (``Cut.owner``)."""
    per_ring = edges.shape[1] - 1
    gb, gs = guess // per_ring, guess % per_ring
    lo2, hi2 = radii[gb] ** 2, radii[gb + 1] ** 2
    c0, s0 = math.cos(edges[gb, gs]), math.sin(edges[gb, gs])
    c1, s1 = math.cos(edges[gb, gs + 1]), math.sin(edges[gb, gs + 1])
    wide = edges[gb, gs + 1] - edges[gb, gs] > math.pi
    out = np.empty(x.shape[0], np.int64)
    for k in range(x.shape[0]):
        px, py = x[k, 0], x[k, 1]
        r2 = px * px + py * py
        if lo2 <= r2 < hi2 and _in_wedge(px, py, c0, s0, c1, s1, wide):
            out[k] = guess
            continue
        b = 0
        while b < radii.size - 2 and radii[b + 1] ** 2 <= r2:
            b += 1
        a = (math.atan2(py, px) - edges[b, 0]) % TWO_PI
        s = 0
        while s < per_ring - 1 and edges[b, s + 1] - edges[b, 0] <= a:
            s += 1
        out[k] = b * per_ring + s
    return out


@nb.njit(**JIT)
def domain_geometry(radii, edges):
    """Per domain [P, 7]: inner and outer radius (m), the unit vectors of its first and last
    edge rays, and 1.0 if its wedge is wider than pi (for ``edge_distance``)."""
    per_ring = edges.shape[1] - 1
    g = np.empty((edges.shape[0] * per_ring, 7))
    for b in range(edges.shape[0]):
        for s in range(per_ring):
            d = b * per_ring + s
            g[d, 0] = radii[b]
            g[d, 1] = radii[b + 1]
            g[d, 2] = math.cos(edges[b, s])
            g[d, 3] = math.sin(edges[b, s])
            g[d, 4] = math.cos(edges[b, s + 1])
            g[d, 5] = math.sin(edges[b, s + 1])
            g[d, 6] = 1.0 if edges[b, s + 1] - edges[b, s] > math.pi else 0.0
    return g


@nb.njit(**JIT)
def edge_distance(px, py, g, rank):
    """Distance (m) of the point (px, py), outside domain ``rank``, from that domain (g:
    ``domain_geometry``). Within the wedge the nearest point is on an arc, straight in or out;
    outside it, on one of the two radial edges (corners included), since the distance to a
    point of an arc grows with the angle between them."""
    if _in_wedge(px, py, g[rank, 2], g[rank, 3], g[rank, 4], g[rank, 5], g[rank, 6] > 0.5):
        r = math.hypot(px, py)
        return max(g[rank, 0] - r, r - g[rank, 1], 0.0)
    return min(_edge_distance(px, py, g[rank, 2], g[rank, 3], g[rank, 0], g[rank, 1]),
               _edge_distance(px, py, g[rank, 4], g[rank, 5], g[rank, 0], g[rank, 1]))


@nb.njit(**JIT)
def _edge_distance(px, py, ex, ey, r_lo, r_hi):
    """Distance of (px, py) from the segment of the ray along (ex, ey) between radii r_lo and
    r_hi (r_hi may be inf)."""
    t = px * ex + py * ey
    if t <= r_lo:
        return math.hypot(px - r_lo * ex, py - r_lo * ey)
    if t >= r_hi:
        return math.hypot(px - r_hi * ex, py - r_hi * ey)
    return abs(px * ey - py * ex)


@nb.njit(**JIT)
def near(x, radii, edges, rank, margin):
    """Mask of the points x [n,2] inside domain ``rank`` or within ``margin`` (m) of it."""
    inside = owners(x, radii, edges, rank) == rank
    g = domain_geometry(radii, edges)
    out = np.empty(x.shape[0], np.bool_)
    for k in range(x.shape[0]):
        out[k] = inside[k] or edge_distance(x[k, 0], x[k, 1], g, rank) < margin
    return out


@nb.njit(**JIT)
def _distance(x, g, rank):
    out = np.empty(x.shape[0])
    for k in range(x.shape[0]):
        out[k] = edge_distance(x[k, 0], x[k, 1], g, rank)
    return out


@nb.njit(**JIT)
def ghost_counts(x, radii, edges, width):
    """Per domain, how many of the points x [n,2] lie outside it within ``width`` (m)."""
    g = domain_geometry(radii, edges)
    own = owners(x, radii, edges, 0)
    out = np.zeros(g.shape[0], np.int64)
    for k in range(x.shape[0]):
        for d in range(g.shape[0]):
            if d != own[k] and edge_distance(x[k, 0], x[k, 1], g, d) < width:
                out[d] += 1
    return out


def angular_edges(hist: np.ndarray, parts: int, first: float | None = None) -> np.ndarray:
    """Edges [parts+1] (rad) of sectors with about equal counts, cut at bin edges of an angular
    histogram (``hist`` [B]: counts in B equal bins over [-pi, pi)). ``first`` (rad): keep the
    first edge at the bin edge nearest this angle (a re-cut: the sectors keep their place and
    order, so only the particles between an old and a new edge migrate); None: start at the
    emptiest bin edge, so that the wrap-around is cheap to cut (the first cut)."""
    if parts == 1:
        return np.array([-math.pi, math.pi])
    bins = hist.size
    cum = np.concatenate([[0], np.cumsum(hist)])
    total = cum[-1]
    if first is None:
        start = int(np.argmin(hist))
    else:
        start = int(round((first + math.pi) / TWO_PI * bins)) % bins
    cum = np.concatenate([cum[start:-1] - cum[start], cum[:start + 1] + total - cum[start]])
    return -math.pi + TWO_PI * (start + _cuts(cum, parts, bins)) / bins


def _cuts(cum: np.ndarray, parts: int, bins: int) -> np.ndarray:
    """Bin-edge indices [parts+1] (0 ... bins) splitting the cumulative counts ``cum`` [bins+1]
    into ``parts`` about equal shares, each part at least one bin wide (it may hold nothing)."""
    cuts = np.searchsorted(cum, cum[-1] * np.arange(1, parts) / parts)
    for k in range(parts - 1):
        low = cuts[k - 1] + 1 if k else 1
        cuts[k] = min(max(cuts[k], low), bins - parts + 1 + k)
    return np.concatenate([[0], cuts, [bins]])


def balanced(hist: np.ndarray, ranks: int, first: float | None = None) -> Cut:
    """Sectors with about equal counts (``angular_edges``)."""
    return sectors(angular_edges(hist, ranks, first))


def ring_radii(hist: np.ndarray, r_top: float, rings: int) -> np.ndarray:
    """Ring boundaries [rings+1] (m; 0 ... inf) with about equal counts, cut at bin edges of a
    radial histogram (``hist`` [B]: counts in B equal bins over [0, r_top))."""
    cum = np.concatenate([[0], np.cumsum(hist)])
    r = r_top * _cuts(cum, rings, hist.size) / hist.size
    r[0], r[-1] = 0.0, math.inf
    return r


def balanced_rings(radii: np.ndarray, hists: np.ndarray, per_ring: int,
                   firsts: np.ndarray | None = None) -> Cut:
    """Rings ``radii`` of ``per_ring`` sectors each with about equal counts (``hists`` [R, B]:
    each ring's angular histogram; ``firsts`` [R]: each ring's first edge to keep, rad, as in
    ``angular_edges``)."""
    firsts = [None] * len(hists) if firsts is None else firsts
    return Cut(radii, np.array([angular_edges(h, per_ring, f) for h, f in zip(hists, firsts)]))


def angle_histogram(x: np.ndarray, bins: int) -> np.ndarray:
    a = np.arctan2(x[:, 1], x[:, 0])
    k = np.clip(((a + math.pi) / TWO_PI * bins).astype(np.int64), 0, bins - 1)
    return np.bincount(k, minlength=bins).astype(np.int64)


def radius_histogram(x: np.ndarray, r_top: float, bins: int) -> np.ndarray:
    k = np.clip((np.hypot(x[:, 0], x[:, 1]) / r_top * bins).astype(np.int64), 0, bins - 1)
    return np.bincount(k, minlength=bins).astype(np.int64)


def ring_histograms(x: np.ndarray, radii: np.ndarray, bins: int) -> np.ndarray:
    """[R, bins]: the angular histogram of the points in each ring."""
    ring = np.searchsorted(radii[1:-1] ** 2, x[:, 0] ** 2 + x[:, 1] ** 2, side="right")
    return np.array([angle_histogram(x[ring == b], bins) for b in range(radii.size - 1)])


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

"""Neighbour search: cell binning + Verlet list with a skin, in canonical (lower gid, higher gid)
order; carrying contact history from the old list to the new one.

Stage: neighbour rebuild (called only when some body has moved more than skin/2 since the last
build, so the list always contains every touching pair). O(N): one counting pass into cells,
then a 3x3-cell scan per particle.

Only touching pairs contribute forces, and each particle's contacts are summed in the order of
the list, so the result does not depend on when the list was rebuilt or on its extra pairs.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .jit import JIT


@nb.njit(**JIT)
def build_pairs(x, radius, gid, n_own, n, skin, pi, pj):
    """Fill pi, pj with all pairs closer than a_i + a_j + skin (centre distance) among the first
    n particles that have a partner among the first n_own (the owned free particles; this
    excludes pairs of two wall disks, of two ghosts, and of a ghost with a wall disk), sorted
    by (gid[pi], gid[pj]) with gid[pi] < gid[pj].
    Returns the number of pairs found; if it exceeds pi.size the arrays hold only a prefix and
    the caller must grow them and call again."""
    cap = pi.size
    if n == 0:
        return 0
    xmin, xmax, ymin, ymax = x[0, 0], x[0, 0], x[0, 1], x[0, 1]
    rmax = 0.0
    for k in range(n):
        xmin = min(xmin, x[k, 0])
        xmax = max(xmax, x[k, 0])
        ymin = min(ymin, x[k, 1])
        ymax = max(ymax, x[k, 1])
        rmax = max(rmax, radius[k])
    cell = 2.0 * rmax + skin
    # A sparse scene would make a huge, mostly empty grid: bound the cell count by ~4 n.
    area = (xmax - xmin + cell) * (ymax - ymin + cell)
    cell = max(cell, math.sqrt(area / (4.0 * n + 16.0)))
    ncx = int((xmax - xmin) / cell) + 1
    ncy = int((ymax - ymin) / cell) + 1
    head = np.full(ncx * ncy, -1, np.int64)
    nxt = np.empty(n, np.int64)
    cx = np.empty(n, np.int64)
    cy = np.empty(n, np.int64)
    for k in range(n):
        cx[k] = min(int((x[k, 0] - xmin) / cell), ncx - 1)
        cy[k] = min(int((x[k, 1] - ymin) / cell), ncy - 1)
        c = cy[k] * ncx + cx[k]
        nxt[k] = head[c]
        head[c] = k
    order = np.argsort(gid[:n])
    buf = np.empty(64, np.int64)
    count = 0
    for oi in range(n):
        i = order[oi]
        gi = gid[i]
        m = 0
        for ix in range(max(cx[i] - 1, 0), min(cx[i] + 2, ncx)):
            for iy in range(max(cy[i] - 1, 0), min(cy[i] + 2, ncy)):
                j = head[iy * ncx + ix]
                while j >= 0:
                    if gid[j] > gi and (i < n_own or j < n_own):
                        dx = x[i, 0] - x[j, 0]
                        dy = x[i, 1] - x[j, 1]
                        cut = radius[i] + radius[j] + skin
                        if dx * dx + dy * dy < cut * cut:
                            if m == buf.size:
                                bigger = np.empty(2 * m, np.int64)
                                bigger[:m] = buf
                                buf = bigger
                            buf[m] = j
                            m += 1
                    j = nxt[j]
        # insertion sort of i's partners by gid (a handful of entries)
        for q in range(1, m):
            b = buf[q]
            r = q - 1
            while r >= 0 and gid[buf[r]] > gid[b]:
                buf[r + 1] = buf[r]
                r -= 1
            buf[r + 1] = b
        for q in range(m):
            if count < cap:
                pi[count] = i
                pj[count] = buf[q]
            count += 1
    return count


@nb.njit(**JIT)
def carry_history(old_lo, old_hi, old_xi, new_lo, new_hi, new_xi):
    """Copy tangential springs from the old list to the new one, matching pairs by their gid keys.
    Both lists are sorted by (lo, hi); pairs absent from the old list start with xi = 0."""
    p = 0
    n_old = old_lo.size
    for k in range(new_lo.size):
        while p < n_old and (old_lo[p] < new_lo[k] or
                             (old_lo[p] == new_lo[k] and old_hi[p] < new_hi[k])):
            p += 1
        if p < n_old and old_lo[p] == new_lo[k] and old_hi[p] == new_hi[k]:
            new_xi[k, 0] = old_xi[p, 0]
            new_xi[k, 1] = old_xi[p, 1]
        else:
            new_xi[k, 0] = 0.0
            new_xi[k, 1] = 0.0


@nb.njit(**JIT)
def ring_candidates(x, radius, n_move, r_in, r_out, skin, out):
    """Indices of free particles within skin of a flat ring surface; returns the count (which may
    exceed out.size, in which case the caller grows ``out`` and calls again)."""
    count = 0
    for i in range(n_move):
        r = math.sqrt(x[i, 0] * x[i, 0] + x[i, 1] * x[i, 1])
        if r - r_in < radius[i] + skin or r_out - r < radius[i] + skin:
            if count < out.size:
                out[count] = i
            count += 1
    return count


def brute_force_pairs(x: np.ndarray, radius: np.ndarray, gid: np.ndarray, kind: np.ndarray,
                      skin: float) -> set[tuple[int, int]]:
    """Reference O(N^2) search (tests only): the set of (gid_lo, gid_hi) within a+a'+skin."""
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=-1)
    cut = radius[:, None] + radius[None, :] + skin
    ii, jj = np.nonzero((d < cut) & (gid[:, None] < gid[None, :]))
    return {(int(gid[i]), int(gid[j])) for i, j in zip(ii, jj) if kind[i] == 0 or kind[j] == 0}

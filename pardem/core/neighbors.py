"""Neighbour search: cell binning + Verlet list with a skin, in canonical (lower gid, higher gid)
order, the ring-contact candidates, and the contact history carried into the new list.

Stage: neighbour rebuild (called only when some free body has moved more than skin/2 since the
last build, or a free body and a wall disk together more than skin + wall_skin, so the list
always contains every touching pair). O(N): one counting pass into cells,
then a 3x3-cell scan per particle over cell-ordered copies of the data.

Only touching pairs contribute forces, and each particle's contacts are summed in the order of
the list, so the result does not depend on when the list was rebuilt or on its extra pairs.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..contact.history import carry_history, live_history
from .jit import JIT
from .sorted_runs import run_order
from ..boundaries.walls import outer_radius, ring_surface

WALL_SKINS = 2.0
"""A free disk's pairs with wall disks are listed up to this many skins farther than free
pairs (Params.wall_skin, ``next_wall_skin``), so that the walls' prescribed motion (the inner
ring turning) rarely forces a build: one comes when a free disk and a wall disk together moved
skin + wall_skin, against skin/2 for the free disks alone."""


def next_wall_skin(travel: float, skin: float) -> float:
    """The wall skin (m) of a build, from the walls' travel (m) over the interval that the build
    ends (``integrate.wall_travel``): enough that walls moving as far again end the next
    interval no sooner than the free disks' own test (which leaves a free disk skin/2), with a
    quarter to spare, and at most WALL_SKINS skins. An interval the walls ended raises it for
    the next. Slow walls get none: in B at 2.5 s a fixed 2 skins listed far free-wall pairs
    that the dense force loop computes, 3.5 % of the step, for no build saved."""
    return min(WALL_SKINS * skin, max(0.0, 1.25 * travel - 0.5 * skin))


@nb.njit(**JIT)
def build_pairs(x, radius, gid, n_own, n_local, n, skin, wall_skin, pi, pj):
    """Fill pi, pj with all pairs closer than a_i + a_j + skin (centre distance) among the first
    n particles that have a partner among the first n_own (the owned free particles; this
    excludes pairs of two wall disks, of two ghosts, and of a ghost with a wall disk), sorted
    by (gid[pi], gid[pj]) with gid[pi] < gid[pj]. Rows n_own:n_local are wall disks: their
    pairs reach wall_skin farther (m).
    Returns the number of pairs found; if it exceeds pi.size the arrays hold only a prefix and
    the caller must grow them and call again.

    Cells are stored CSR-style (a counting sort by cell, with cell-ordered copies of position,
    radius and gid), so a 3x3 cell scan reads contiguous memory; candidates are appended without
    a branch (both tests are unpredictable), which made the build ~3x faster."""
    cap = pi.size
    if n == 0:
        return 0
    xmin, xmax, ymin, ymax = x[0, 0], x[0, 0], x[0, 1], x[0, 1]
    rmax = 0.0  # free particles (owned and ghosts)
    rwall = 0.0
    for k in range(n):
        xmin = min(xmin, x[k, 0])
        xmax = max(xmax, x[k, 0])
        ymin = min(ymin, x[k, 1])
        ymax = max(ymax, x[k, 1])
        if n_own <= k < n_local:
            rwall = max(rwall, radius[k])
        else:
            rmax = max(rmax, radius[k])
    # a 3x3 cell scan must reach every listed partner
    cell = max(2.0 * rmax + skin, rmax + rwall + skin + wall_skin)
    # A sparse scene would make a huge, mostly empty grid: bound the cell count by ~4 n.
    area = (xmax - xmin + cell) * (ymax - ymin + cell)
    cell = max(cell, math.sqrt(area / (4.0 * n + 16.0)))
    ncx = int((xmax - xmin) / cell) + 1
    ncy = int((ymax - ymin) / cell) + 1
    # int32 cell ids, slots and rows (local indices are int32, as in Pairs): the build's
    # temporaries are part of a rank's peak memory at 10^6 disks. They are widened to int64
    # where they are read: int32 arithmetic made build_pairs 17 % slower (B at 2.5 s).
    start = np.zeros(ncx * ncy + 1, np.int32)  # cell c holds slots start[c]:start[c + 1]
    cid = np.empty(n, np.int32)
    for k in range(n):
        cx = min(int((x[k, 0] - xmin) / cell), ncx - 1)
        cy = min(int((x[k, 1] - ymin) / cell), ncy - 1)
        c = cy * ncx + cx
        cid[k] = c
        start[c + 1] += 1
    most = 0
    for c in range(ncx * ncy):
        most = max(most, start[c + 1])
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    sx = np.empty(n)
    sy = np.empty(n)
    sr = np.empty(n)
    sg = np.empty(n, np.int64)
    sk = np.empty(n, np.int32)
    for k in range(n):
        c = np.int64(cid[k])
        s = np.int64(fill[c])
        fill[c] += 1
        sx[s] = x[k, 0]
        sy[s] = x[k, 1]
        sr[s] = radius[k]
        sg[s] = gid[k]
        sk[s] = k
    order = run_order(gid, n)  # the rows are a few ascending runs of gids
    buf = np.empty(9 * most + 1, np.int64)
    count = 0
    for oi in range(n):
        i = np.int64(order[oi])
        if n_own <= i < n_local:
            # a wall disk lists nothing: its partners are free disks, whose gids are lower
            # (free disks come first), so its pairs are found from their side. Scanning its
            # cells anyway cost (wall disks per cell)^2: 10^6 disks on one ring took minutes
            continue
        gi = gid[i]
        xi_ = x[i, 0]
        yi_ = x[i, 1]
        ri = radius[i] + skin
        own_i = i < n_own
        ci = np.int64(cid[i])
        cx = ci % ncx
        cy = ci // ncx
        m = 0
        for iy in range(max(cy - 1, 0), min(cy + 2, ncy)):
            row = iy * ncx
            for s in range(np.int64(start[row + max(cx - 1, 0)]),
                           np.int64(start[row + min(cx + 2, ncx)])):
                dx = xi_ - sx[s]
                dy = yi_ - sy[s]
                kj = np.int64(sk[s])
                cut = ri + sr[s] + wall_skin * ((n_own <= kj) & (kj < n_local))
                buf[m] = s  # the slot is overwritten unless the candidate is kept
                m += (sg[s] > gi) & (own_i | (kj < n_own)) & (dx * dx + dy * dy < cut * cut)
        # insertion sort of i's partners by gid (a handful of entries)
        for q in range(1, m):
            b = buf[q]
            r = q - 1
            while r >= 0 and sg[buf[r]] > sg[b]:
                buf[r + 1] = buf[r]
                r -= 1
            buf[r + 1] = b
        for q in range(m):
            if count < cap:
                pi[count] = i
                pj[count] = sk[buf[q]]
            count += 1
    return count


@nb.njit(**JIT)
def ring_candidates(x, radius, n_owned, r_o, skin, rings, out):
    """Indices of free particles within skin of a flat ring surface that is a contact surface
    (outer radius r_o now); returns the count (which may exceed out.size, in which case the
    caller grows ``out`` and calls again)."""
    count = 0
    for i in range(n_owned):
        ring = ring_surface(x[i, 0], x[i, 1], radius[i], skin, r_o, rings).ring
        if ring != 0:
            if count < out.size:
                out[count] = i
            count += 1
    return count


@nb.njit(**JIT)
def build_lists(ps, pairs, clock, prm, t, from_list, history, walls):
    """A neighbour build's lists in one compiled call (at a build, each call from Python costs
    tens of us): reference positions and outer radius for the skin test, the pair list
    (``build_pairs``) with the history carried over (``carry_history``; from the current list
    if ``from_list``, else from ``history`` = (lo, hi, rows)), and, with ``walls``, the ring
    candidates (``ring_candidates``). Returns ``(count, n_wall, history)``. If count or n_wall
    exceeds the capacity of pairs, the lists are unusable: grow them and call again with the
    returned history."""
    if from_list:
        history = live_history(ps.gid, pairs.i, pairs.j, pairs.hist, pairs.count[0])
    n = clock.n_local[0] + clock.n_ghost[0]
    n_owned = clock.n_owned[0]
    for k in range(n):
        ps.x_ref[k, 0] = ps.x[k, 0]
        ps.x_ref[k, 1] = ps.x[k, 1]
    r_out = outer_radius(t, prm.rings)[0]
    clock.r_out_ref[0] = r_out
    clock.step_ref[0] = clock.step[0]
    count = build_pairs(ps.x, ps.radius, ps.gid, n_owned, clock.n_local[0], n, prm.skin,
                        prm.wall_skin, pairs.i, pairs.j)
    n_wall = 0
    if walls:
        n_wall = ring_candidates(ps.x, ps.radius, n_owned, r_out, prm.skin, prm.rings, pairs.wall)
    if count <= pairs.i.size and n_wall <= pairs.wall.size:
        if pairs.hist.shape[0] > 0:
            carry_history(history[0], history[1], history[2], ps.gid, pairs.i, pairs.j,
                          pairs.hist[:count])
        pairs.count[0] = count
        pairs.wall_count[0] = n_wall
    return count, n_wall, history

"""Contact forces of the current positions: the pair loop and the flat ring contacts.

Stage: forces (inside the step loop, ``step.py``). Reads positions, predicted velocities and
spins, radii and the pair list; writes each particle's force and torque, each pair's history
(spring, rolling spring, eta) and the forces each pair and ring contact applied (``Pairs.fn``,
``ft``, ``wall_fn``, ``wall_ft``: what output and averaging report). The contact law itself
(which slots, their parameters and history) is ``contact.model``; nothing here depends on it
beyond the number of history columns.

Rank independence: the pairs come in canonical (lower gid, higher gid) order and every pair
is computed in that orientation, so each particle's contacts are added in gid order on any
number of ranks, and a pair seen by two ranks gets the same bits on both.
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from ..contact.lanes import (ACT_DEEP, ACT_NONE, ACT_TOUCH, BATCH, W_ACT, W_AI, W_AJ, W_DVX, W_DVY, W_DX, W_DY, W_FN, W_FTX, W_FTY,
                             W_FX, W_FY, W_HIST, W_TI, W_TJ, W_WI, W_WJ, gather_law, gather_masses,
                             lane_contact, work_size)
from ..contact.damping import per_contact
from ..contact.model import history_width
from ..contact.overlap import lane_overlap, note_deep, too_deep
from .jit import INLINE, JIT
from .pair_select import select_pairs, zero_pairs
from ..boundaries.ring_forces import ring_contacts


# The selection pays while fewer than this fraction of the listed pairs have a force (B in
# steady shear: 0.27; B at 20 s, still dense: 0.63); above it every listed pair goes to the
# law. The selecting loop measures the fraction at every call; while every pair is computed,
# it is counted every RECHECK calls (a vectorised pass over the law's output, ~1 % of the
# call), so a packing that loosens is noticed. ``work``'s last two elements keep the fraction
# and the calls since it was counted. A list whose data no longer stays in the caches (more
# than LARGE_LIST pairs: the loop's cost per pair doubles between 7e4 and 2e5 pairs on the
# machine measured) pays for every history row it reads, and the selection wins up to a higher
# fraction there (the 1M cell: 1.11 times as fast at 0.51, the crossing near 0.65; the 300k
# cell's near 0.55; docs/scaling.md). Both loops give the same bits.
SELECT_BELOW = 0.5
SELECT_BELOW_LARGE = 0.55
LARGE_LIST = 100_000
RECHECK = 100


@nb.njit(**INLINE)
def select_below(n_pairs):
    """The fraction of pairs with a force below which a list of n_pairs goes through the
    selecting loop."""
    return SELECT_BELOW_LARGE if n_pairs > LARGE_LIST else SELECT_BELOW


class ForceWork(NamedTuple):
    """What contact_forces keeps from call to call within one pair list.

    rows: the law's work rows (lanes.work_size), whose last two elements keep the loop's
    choice: the fraction of pairs with a force and the calls since it was counted.
    live [2, cap] int32, n_live [2] int64: the pairs selected_pairs gave to the law at its
    last call (row n_live[0], n_live[1] of them, in list order), or n_live[0] = -1 when
    unknown. Every other pair's history is +0.0, so the next selecting call zeroes only those
    of these it leaves out, instead of writing every listed pair's history (at 300k disks on
    one rank, ~22 MB per step that the caches cannot hold). A new list needs a new ForceWork:
    the selection is kept as indices into the list.
    deep [3] float: the deepest contact of the last call beyond MAX_OVERLAP of its smaller
    diameter: (pair index, or the particle's index for a ring surface; -1: none), the overlap
    over that diameter, the ring (0: a pair, 1 inner, 2 outer)."""

    rows: np.ndarray
    live: np.ndarray
    n_live: np.ndarray
    deep: np.ndarray


@nb.njit(**JIT)
def new_work(o, capacity):
    """contact_forces' work for a run of calls on a list of up to ``capacity`` pairs; its
    choice starts with every pair computed and counted."""
    rows = np.zeros(work_size(o))
    rows[rows.size - 1] = 1.0
    rows[rows.size - 2] = RECHECK
    return ForceWork(rows, np.empty((2, capacity), np.int32), np.array([-1, 0]),
                     np.array([-1.0, 0.0, 0.0]))


@nb.njit(**JIT)
def contact_forces(ps, pairs, n_loc, prm, t, reach, o, rotation, walls, work, record):
    """Pair contacts in canonical order, then flat ring contacts -> ps.f, ps.tau (of the first
    n_loc particles), histories and recorded forces. ``o``: contact.model.ContactOptions.

    The pairs go through the law in batches of BATCH, so that it runs in SIMD lanes, one pair
    per lane (one fused loop was bound by the latency of a pair's ~100-cycle chain of dependent
    square root and divisions, with 1-2 pairs in flight): every listed pair (every_pair), or
    only those close enough to have a force this step (selected_pairs), whichever the fraction
    of pairs with a force favours. Both give the same bits. ``work``: a flat
    (lanes.work_size) float array, kept from call to call. ``record``: store the applied
    forces (Pairs.fn, ft, wall_fn, wall_ft), which only output and averaging read, so the step
    loop asks for them at the last step of a call only (stored every step, they cost ~8 % of
    the step: 24 bytes per pair of extra memory traffic)."""
    sf, st = ps.f.reshape(-1), ps.tau
    work.deep[0] = -1.0
    work.deep[1] = 0.0
    for k in range(2 * n_loc):
        sf[k] = 0.0
    for k in range(n_loc):
        st[k] = 0.0
    rows = work.rows
    calls = rows[rows.size - 2]
    if rows[rows.size - 1] < select_below(pairs.count[0]):
        rows[rows.size - 1] = selected_pairs(ps, pairs, prm, reach, o, rotation, work, record)
    else:
        work.n_live[0] = -1  # every pair's history written: the next selection zeroes all
        # a run-time flag, not two literal calls: each literal is a compile of its own, and
        # every_pair is the largest kernel (6.4 s of a cold start on this machine)
        measure = calls >= RECHECK
        fraction = every_pair(ps, pairs, prm, reach, o, rotation, rows, record, measure,
                              work.deep)
        rows[rows.size - 1] = fraction if measure else rows[rows.size - 1]
        rows[rows.size - 2] = 0.0 if measure else calls + 1.0
    if walls:
        ring_contacts(ps, pairs, prm, t, reach, o, rotation, record, work.deep)


@nb.njit(**JIT)
def every_pair(ps, pairs, prm, reach, o, rotation, work, record, measure, deep):
    """Every listed pair through three loops per batch:
      gather   copy each pair's inputs into the work rows (unsigned indices: numba then adds
               no negative-index wrap-around, which spilled registers here);
      law      the contact law on the work rows only, at unit stride, so LLVM vectorises it
               without alias checks; the Coulomb cap and the damping window's partial weight
               with selects, so no lane is redone: the same bits as the scalar law;
      scatter  forces and torques added in list order. Pairs come sorted by their lower
               particle, so its sums stay in registers along its run of pairs: the same
               additions in the same order as f[i] += ... pair by pair, without a chain of
               stores and reloads through memory.
    The flat views are made once here: made per batch, their reference counting cost more
    than the gather. selected_pairs repeats the gather and the scatter: made inline
    functions shared by both, they made this loop twice as slow (B at 20 s, one process,
    alternated: 123 against 63 ns per particle). With ``measure``, returns the fraction of
    the listed pairs with a normal force (else 0): counted here rather than by a call of
    selected_pairs, which costs a dense packing more than the count (B at 2.5 s: 2-3 % of the
    step, with a selecting call every 100 and at every build), and apart from the scatter,
    whose serial chain an added count lengthened by ~7 %. ``deep``: ForceWork.deep, where a
    pair overlapping beyond MAX_OVERLAP is noted (flagged in the law's loop, measured in the
    scatter)."""
    n_hist = history_width(o)
    hw = np.uint64(n_hist)
    gx, gv, gw, ga = ps.x.reshape(-1), ps.v_pred.reshape(-1), ps.w_pred, ps.radius
    sf, st, sxi = ps.f.reshape(-1), ps.tau, pairs.hist.reshape(-1)
    rfn, rft = pairs.fn, pairs.ft.reshape(-1)
    pi, pj = pairs.i, pairs.j
    one = np.uint64(1)
    h_in = np.uint64(W_HIST * BATCH)
    h_out = h_in + hw * np.uint64(BATCH)
    n_pairs = pairs.count[0]
    n_force = 0
    for first in range(0, n_pairs, BATCH):
        m = min(BATCH, n_pairs - first)
        for ln in range(m):
            kk = np.uint64(first + ln)
            ii = np.uint64(pi[kk])
            jj = np.uint64(pj[kk])
            work[W_DX * BATCH + ln] = gx[ii + ii] - gx[jj + jj]
            work[W_DY * BATCH + ln] = gx[ii + ii + one] - gx[jj + jj + one]
            work[W_AI * BATCH + ln] = ga[ii]
            work[W_AJ * BATCH + ln] = ga[jj]
            work[W_DVX * BATCH + ln] = gv[ii + ii] - gv[jj + jj]
            work[W_DVY * BATCH + ln] = gv[ii + ii + one] - gv[jj + jj + one]
            work[W_WI * BATCH + ln] = gw[ii] if rotation else 0.0
            work[W_WJ * BATCH + ln] = gw[jj] if rotation else 0.0
            if o.pairs:
                gather_law(work, ln, prm.pair_law, ps.species[ii], ps.species[jj], o)
            if per_contact(o):
                gather_masses(work, ln, ps.inv_mass[ii], ps.inv_mass[jj], o)
            for c in range(n_hist):
                work[h_in + np.uint64(c * BATCH + ln)] = sxi[kk * hw + np.uint64(c)]
        for ln in range(BATCH):  # lanes past m: stale inputs, outputs never read
            touching = lane_contact(work, ln, reach, prm.law, o)
            work[W_ACT * BATCH + ln] = ((ACT_DEEP if too_deep(work, ln) else ACT_TOUCH) if touching
                                        else ACT_NONE)
        if measure:
            for ln in range(m):
                n_force += 1 if work[W_FN * BATCH + ln] != 0.0 else 0
        cur = np.uint64(pi[first])
        acc_x = sf[cur + cur]
        acc_y = sf[cur + cur + one]
        acc_t = st[cur]
        if record:
            for ln in range(m):
                kr = first + ln
                rfn[kr] = work[W_FN * BATCH + ln]
                rft[kr + kr] = work[W_FTX * BATCH + ln]
                rft[kr + kr + 1] = work[W_FTY * BATCH + ln]
        for ln in range(m):
            kk = np.uint64(first + ln)
            for c in range(n_hist):  # a pair that does not touch comes back with zeros
                sxi[kk * hw + np.uint64(c)] = work[h_out + np.uint64(c * BATCH + ln)]
            ii = np.uint64(pi[kk])
            if ii != cur:
                sf[cur + cur] = acc_x
                sf[cur + cur + one] = acc_y
                st[cur] = acc_t
                cur = ii
                acc_x = sf[cur + cur]
                acc_y = sf[cur + cur + one]
                acc_t = st[cur]
            if work[W_ACT * BATCH + ln] != ACT_NONE:
                jj = np.uint64(pj[kk])
                if work[W_ACT * BATCH + ln] > ACT_TOUCH:  # ACT_DEEP; == measured 10 % slower
                    delta, diameter = lane_overlap(work, ln, ps.kind[ii], ps.kind[jj])
                    note_deep(deep, float(kk), delta, diameter, 0.0)
                acc_x += work[W_FX * BATCH + ln]
                acc_y += work[W_FY * BATCH + ln]
                sf[jj + jj] -= work[W_FX * BATCH + ln]
                sf[jj + jj + one] -= work[W_FY * BATCH + ln]
                if rotation:
                    acc_t += work[W_TI * BATCH + ln]
                    st[jj] += work[W_TJ * BATCH + ln]
        sf[cur + cur] = acc_x
        sf[cur + cur + one] = acc_y
        st[cur] = acc_t
    return n_force / n_pairs if n_pairs else 0.0


@nb.njit(**JIT)
def selected_pairs(ps, pairs, prm, reach, o, rotation, wk, record):
    """every_pair's loops on the listed pairs close enough to have a force (select_pairs): in
    steady shear about a quarter of them (B at 239 s: 1,916 of 7,195). Pairs are queued in
    list order until a batch is full; the stored histories (and recorded forces) of the pairs
    up to a batch's last are set to zero in one contiguous pass after its gather, and those
    left out keep the zeros. The law gives a pair left out exactly zero (forces, springs, eta),
    and a sum that starts at +0.0 keeps its bits when a zero is not added, so the results
    equal every_pair's. When the previous call's selection is known (``wk.live``) and no
    forces are recorded, only the pairs of that selection left out now are zeroed: the others
    already hold +0.0, so memory ends the same. Returns the fraction of the listed pairs with
    a normal force."""
    n_hist = history_width(o)
    hw = np.uint64(n_hist)
    gx, gv, gw, ga = ps.x.reshape(-1), ps.v_pred.reshape(-1), ps.w_pred, ps.radius
    sf, st, sxi = ps.f.reshape(-1), ps.tau, pairs.hist.reshape(-1)
    rfn, rft = pairs.fn, pairs.ft.reshape(-1)
    pi, pj = pairs.i, pairs.j
    one = np.uint64(1)
    h_in = np.uint64(W_HIST * BATCH)
    h_out = h_in + hw * np.uint64(BATCH)
    h = 0.5 * prm.law.dt if o.damping and o.window else 0.0
    deep = wk.deep
    queue = np.empty(2 * BATCH, np.int64)  # selected pairs waiting for a batch, in list order
    keep = np.empty(BATCH, np.int64)
    n_pairs = pairs.count[0]
    n_force = 0
    q = 0  # pairs queued
    scanned = 0  # pairs [0, scanned) selected
    zeroed = 0  # pairs [0, zeroed) have had their stored history (and record) set to zero
    work, was = wk.rows, wk.n_live[0]
    sparse = was >= 0 and not record
    old = wk.live[max(was, 0)]  # the previous selection, zeroed where left out now
    new = wk.live[1 if was == 0 else 0]
    n_old, p_old, n_new = wk.n_live[1] if sparse else 0, 0, 0
    while scanned < n_pairs or q > 0:
        if scanned < n_pairs:
            mm = min(BATCH, n_pairs - scanned)
            q = select_pairs(gx, gv, ga, pi, pj, scanned, mm, h, keep, queue, q)
            while p_old < n_old and old[p_old] < scanned + mm:
                if keep[old[p_old] - scanned] == 0:
                    zero_pairs(sxi, rfn, rft, old[p_old], old[p_old] + 1, n_hist, False)
                p_old += 1
            scanned += mm
            if q < BATCH and scanned < n_pairs:
                continue
        m = min(q, BATCH)
        for ln in range(m):
            new[n_new + ln] = queue[ln]
        n_new += m
        for ln in range(m):
            kk = np.uint64(queue[ln])
            ii = np.uint64(pi[kk])
            jj = np.uint64(pj[kk])
            work[W_DX * BATCH + ln] = gx[ii + ii] - gx[jj + jj]
            work[W_DY * BATCH + ln] = gx[ii + ii + one] - gx[jj + jj + one]
            work[W_AI * BATCH + ln] = ga[ii]
            work[W_AJ * BATCH + ln] = ga[jj]
            work[W_DVX * BATCH + ln] = gv[ii + ii] - gv[jj + jj]
            work[W_DVY * BATCH + ln] = gv[ii + ii + one] - gv[jj + jj + one]
            work[W_WI * BATCH + ln] = gw[ii] if rotation else 0.0
            work[W_WJ * BATCH + ln] = gw[jj] if rotation else 0.0
            if o.pairs:
                gather_law(work, ln, prm.pair_law, ps.species[ii], ps.species[jj], o)
            if per_contact(o):
                gather_masses(work, ln, ps.inv_mass[ii], ps.inv_mass[jj], o)
            for c in range(n_hist):
                work[h_in + np.uint64(c * BATCH + ln)] = sxi[kk * hw + np.uint64(c)]
        upto = queue[m - 1] + 1 if m > 0 else n_pairs
        if not sparse:
            zero_pairs(sxi, rfn, rft, zeroed, upto, n_hist, record)
            zeroed = upto
        if m == 0:
            break
        for ln in range(BATCH):  # lanes past m: stale inputs, outputs never read
            touching = lane_contact(work, ln, reach, prm.law, o)
            work[W_ACT * BATCH + ln] = ((ACT_DEEP if too_deep(work, ln) else ACT_TOUCH) if touching
                                        else ACT_NONE)
        cur = np.uint64(pi[queue[0]])
        acc_x = sf[cur + cur]
        acc_y = sf[cur + cur + one]
        acc_t = st[cur]
        for ln in range(m):
            kk = np.uint64(queue[ln])
            if record:
                rfn[kk] = work[W_FN * BATCH + ln]
                rft[kk + kk] = work[W_FTX * BATCH + ln]
                rft[kk + kk + one] = work[W_FTY * BATCH + ln]
            for c in range(n_hist):
                sxi[kk * hw + np.uint64(c)] = work[h_out + np.uint64(c * BATCH + ln)]
            ii = np.uint64(pi[kk])
            if ii != cur:
                sf[cur + cur] = acc_x
                sf[cur + cur + one] = acc_y
                st[cur] = acc_t
                cur = ii
                acc_x = sf[cur + cur]
                acc_y = sf[cur + cur + one]
                acc_t = st[cur]
            n_force += 1 if work[W_FN * BATCH + ln] != 0.0 else 0
            if work[W_ACT * BATCH + ln] != ACT_NONE:
                jj = np.uint64(pj[kk])
                if work[W_ACT * BATCH + ln] > ACT_TOUCH:  # ACT_DEEP (see above)
                    delta, diameter = lane_overlap(work, ln, ps.kind[ii], ps.kind[jj])
                    note_deep(deep, float(kk), delta, diameter, 0.0)
                acc_x += work[W_FX * BATCH + ln]
                acc_y += work[W_FY * BATCH + ln]
                sf[jj + jj] -= work[W_FX * BATCH + ln]
                sf[jj + jj + one] -= work[W_FY * BATCH + ln]
                if rotation:
                    acc_t += work[W_TI * BATCH + ln]
                    st[jj] += work[W_TJ * BATCH + ln]
        sf[cur + cur] = acc_x
        sf[cur + cur + one] = acc_y
        st[cur] = acc_t
        for ln in range(m, q):
            queue[ln - m] = queue[ln]
        q -= m
    if not sparse:
        zero_pairs(sxi, rfn, rft, zeroed, n_pairs, n_hist, record)
    wk.n_live[0] = 1 if was == 0 else 0
    wk.n_live[1] = n_new
    return n_force / n_pairs if n_pairs else 0.0

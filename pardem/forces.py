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

import numba as nb
import numpy as np

from .contact.model import (BATCH, W_ACT, W_AI, W_AJ, W_DVX, W_DVY, W_DX, W_DY, W_FN, W_FTX,
                            W_FTY, W_FX, W_FY, W_HIST, W_TI, W_TJ, W_WI, W_WJ,
                            history_width, lane_contact, surface_contact)
from .jit import JIT
from .walls import outer_radius, ring_surface


@nb.njit(**JIT)
def contact_forces(ps, pairs, n_loc, prm, t, reach, o, rotation, walls, work, record):
    """Pair contacts in canonical order, then flat ring contacts -> ps.f, ps.tau (of the first
    n_loc particles), histories and recorded forces. ``o``: contact.model.ContactOptions.

    The pairs go through three loops in batches of BATCH, so that the contact law runs in SIMD
    lanes, one pair per lane. (One fused loop was bound by the latency of a pair's ~100-cycle
    chain of dependent square root and divisions, with 1-2 pairs in flight.)
      gather   copy each pair's inputs into the work rows (unsigned indices: numba then adds
               no negative-index wrap-around, which spilled registers here);
      law      the contact law on the work rows only, at unit stride, so LLVM vectorises it
               without alias checks; the Coulomb cap and the damping window's partial weight
               with selects (sliding and barely touching contacts are common in steady
               shear), so no lane is redone: the same bits as the scalar law;
      scatter  forces and torques added in list order. Pairs come sorted by their lower
               particle, so its sums stay in registers along its run of pairs: the same
               additions in the same order as f[i] += ... pair by pair, without a chain of
               stores and reloads through memory.
    ``work``: a flat (model.work_size) float array. The flat views are made once here: made
    per batch, their reference counting cost more than the gather. ``record``: store the
    applied forces (Pairs.fn, ft, wall_fn, wall_ft), which only output and averaging read, so
    the step loop asks for them at the last step of a call only (stored every step, they cost
    ~8 % of the step: 24 bytes per pair of extra memory traffic)."""
    n_hist = history_width(o)
    hw = np.uint64(n_hist)
    gx, gv, gw, ga = ps.x.reshape(-1), ps.v_pred.reshape(-1), ps.w_pred, ps.radius
    sf, st, sxi = ps.f.reshape(-1), ps.tau, pairs.hist.reshape(-1)
    rfn, rft = pairs.fn, pairs.ft.reshape(-1)
    pi, pj = pairs.i, pairs.j
    for k in range(2 * n_loc):
        sf[k] = 0.0
    for k in range(n_loc):
        st[k] = 0.0
    one = np.uint64(1)
    h_in = np.uint64(W_HIST * BATCH)
    h_out = h_in + hw * np.uint64(BATCH)
    n_pairs = pairs.count[0]
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
            for c in range(n_hist):
                work[h_in + np.uint64(c * BATCH + ln)] = sxi[kk * hw + np.uint64(c)]
        for ln in range(BATCH):  # lanes past m: stale inputs, outputs never read
            touching, _ = lane_contact(work, ln, reach, prm.law, o, True)  # nothing deferred
            work[W_ACT * BATCH + ln] = 1.0 if touching else 0.0
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
            if work[W_ACT * BATCH + ln] != 0.0:
                jj = np.uint64(pj[kk])
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
    if walls:
        ring_contacts(ps, pairs, prm, t, reach, o, rotation, record)


@nb.njit(**JIT)
def ring_contacts(ps, pairs, prm, t, reach, o, rotation, record):
    """Contacts of candidate free particles with the two flat ring surfaces (infinitely
    massive; walls.ring_surface gives the geometry and the surface's motion)."""
    has_hist = history_width(o) > 0
    r_o, r_o_dot = outer_radius(t, prm.rings)
    lim = reach if o.damping and o.window else 0.0
    for q in range(pairs.wall_count[0]):
        i = pairs.wall[q]
        a = ps.radius[i]
        ring, nx, ny, delta, vjx, vjy, s_j, w_j = ring_surface(ps.x[i, 0], ps.x[i, 1], a, lim,
                                                               r_o, r_o_dot, prm.rings)
        if ring == 0:
            if has_hist:
                ps.hist_wall[i, :] = 0.0
            if record:
                pairs.wall_fn[q] = 0.0
                pairs.wall_ft[q, 0] = 0.0
                pairs.wall_ft[q, 1] = 0.0
            continue
        w_i = ps.w_pred[i] if rotation else 0.0
        s = (a * ps.w_pred[i] if rotation else 0.0) + s_j
        fn, ftx, fty, torque = surface_contact(
            (nx, ny), delta, a, (ps.v_pred[i, 0] - vjx + s * ny, ps.v_pred[i, 1] - vjy - s * nx),
            (w_i, w_j), ps.hist_wall, i, prm.law, o)
        if record:
            pairs.wall_fn[q] = fn
            pairs.wall_ft[q, 0] = ftx
            pairs.wall_ft[q, 1] = fty
        ps.f[i, 0] += fn * nx + ftx
        ps.f[i, 1] += fn * ny + fty
        if rotation:
            ps.tau[i] += torque

"""The time-step loop: velocity Verlet with contact forces, compiled once per set of effects.

Stage: integration. ``make_stepper(options)`` returns a ``Stepper`` of jitted functions that run
many steps per Python call. One step (LAMMPS ``Verlet::iterate`` order):

    half kick   v += dt/2 f/m, w += dt/2 tau/I
    drift       x += dt v, theta += dt w;  rings and wall disks moved to t + dt;
                predict v(t+dt) = v + dt/2 f(t)/m for the velocity-dependent forces
    ghosts      under MPI: neighbours' boundary particles refreshed (x, v_pred, w_pred), and
                every rank learns the global largest displacement and speed (mpi_native.py)
    (stop here and return NEED_REBUILD if a pair not in the list could now be within reach
     of touching: largest displacement since the last neighbour build + half the distance
     the fastest body covers in a step > skin/2; the caller rebuilds the list, under MPI
     migrating particles between ranks when ``exchange_due``, and calls ``advance`` again,
     which resumes)
    forces      pair contacts in canonical pair order, then flat ring contacts
    half kick   (then bottom friction)

Time is ``step * dt`` (never accumulated). Bottom friction acts in the closing kick as a
velocity-space Coulomb friction: it removes at most mu_b g dt of speed per step and never
reverses the velocity, so a disk at rest with small loads stays exactly at rest and nothing
divides by zero.

Reads/writes: Particles, Pairs (springs), Clock; reads Params, Halo.

Rank independence: each rank stores [owned free particles | all wall disks | ghosts]; the pair
list holds every pair with an owned partner, sorted by (lower gid, higher gid), so each owned
particle's contacts are added in gid order on any number of ranks, and a pair seen by two ranks
is computed from the same inputs in the same orientation on both. The only global quantities
(largest displacement and speed) are maxima, which are exact.

The stages are module-level jitted functions taking the effect switches as arguments (the
``fx`` tuple: damping, friction, clip, rotation, bottom_friction, walls, the integrator's
prediction, which also switches the damping window, and eta: whether the paper's total
tangential displacement is tracked beside the spring) and inlined into
``advance``, a closure over nothing but those booleans: they are compile-time constants there,
so a disabled effect is compiled out, and numba's disk cache can serve the kernels to later
processes (closures that capture other jitted functions get a new cache key in every process).
"""

from __future__ import annotations

import functools
import math
from typing import Callable, NamedTuple

import numba as nb
import numpy as np

from .contact import (LawOptions, contact_law, pair_displacement, pair_force,
                      tangential_displacement)
from .jit import INLINE, JIT
from .mpi_native import refresh_ghosts
from .state import OUTER_WALL
from .walls import outer_radius, outer_ring_settled, place_wall_disks

OK, NEED_REBUILD, BAD_PARTICLE, MPI_FAILED = 0, 1, 2, 3


class StepOptions(NamedTuple):
    """Compile-time switches of one scene (hashable). ``walls``: Couette rings are present.
    The integrator ([time] integrator) sets ``predict`` and ``law.window`` together."""

    law: LawOptions = LawOptions()
    rotation: bool = True
    bottom_friction: bool = True
    walls: bool = True
    predict: bool = True  # velocity-dependent forces use v + dt/2 a (else the half-step v)
    eta: bool = False  # track the paper's total tangential displacement (history columns 2-3)


class Stepper(NamedTuple):
    """Compiled functions of one scene: ``advance(ps, pairs, clock, prm, halo, target_step) ->
    (status, particle_index)`` and ``compute_forces(ps, pairs, clock, prm, v2_max)``."""

    advance: Callable
    compute_forces: Callable


BATCH = 64  # pairs per batch: the work rows (19 x 64 doubles, 10 kB; 23 with eta) stay in L1
# rows of the work array: inputs of pair_force, its outputs, the lanes to redo, and eta in/out
(W_DX, W_DY, W_AI, W_AJ, W_DVX, W_DVY, W_WI, W_WJ, W_XIX, W_XIY,
 W_ACT, W_FX, W_FY, W_TI, W_TJ, W_XOX, W_XOY, W_REDO, W_LANE,
 W_ETX, W_ETY, W_EOX, W_EOY) = range(23)
WORK_ROWS = 23


@nb.njit(**INLINE)
def forces(ps, pairs, n_loc, prm, t, reach, fx, work):
    """Pair contacts in canonical order, then flat ring contacts -> ps.f, ps.tau, springs.

    The pairs go through four loops in batches of BATCH, so that the contact law runs in SIMD
    lanes, one pair per lane. (One fused loop was bound by the latency of a pair's ~100-cycle
    chain of dependent square root and divisions, with 1-2 pairs in flight.)
      gather   copy each pair's inputs into the work rows (unsigned indices: numba then adds
               no negative-index wrap-around, which spilled registers here);
      law      pair_force on the work rows only, at unit stride, so LLVM vectorises it without
               alias checks; the rare branches (Coulomb cap, partial damping window) are
               deferred;
      redo     the few deferred pairs (~4 %: sliding or just touching), scalar, with the full
               law: the same bits as computing every pair with it;
      scatter  forces and torques added in list order. Pairs come sorted by their lower
               particle, so its sums stay in registers along its run of pairs: the same
               additions in the same order as f[i] += ... pair by pair, without a chain of
               stores and reloads through memory.
    ``work``: a flat (WORK_ROWS * BATCH) float array. The flat views are made once here: made
    per batch, their reference counting cost more than the gather."""
    friction, rotation, walls, eta = fx[1], fx[3], fx[5], fx[7]
    hw = np.uint64(4 if eta else 2)  # history columns per pair: spring (and eta)
    gx, gv, gw, ga = ps.x.reshape(-1), ps.v_pred.reshape(-1), ps.w_pred, ps.radius
    sf, st, sxi = ps.f.reshape(-1), ps.tau, pairs.xi.reshape(-1)
    pi, pj = pairs.i, pairs.j
    for k in range(2 * n_loc):
        sf[k] = 0.0
    for k in range(n_loc):
        st[k] = 0.0
    one = np.uint64(1)
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
            work[W_XIX * BATCH + ln] = sxi[kk * hw] if friction else 0.0
            work[W_XIY * BATCH + ln] = sxi[kk * hw + one] if friction else 0.0
            if eta:
                work[W_ETX * BATCH + ln] = sxi[kk * hw + np.uint64(2)]
                work[W_ETY * BATCH + ln] = sxi[kk * hw + np.uint64(3)]
        for ln in range(BATCH):  # lanes past m: stale inputs, outputs never read
            touching, flagged = lane_law(work, ln, reach, prm, fx, True)
            work[W_ACT * BATCH + ln] = 1.0 if touching else 0.0
            work[W_REDO * BATCH + ln] = 1.0 if flagged else 0.0
        # A plain loop over the lanes "if flagged" would be vectorised with every lane computed;
        # through a list of lanes it stays scalar. (Loop names differ from the inlined
        # callees' names: see jit.py.)
        n_redo = 0
        for ln in range(m):
            if work[W_REDO * BATCH + ln] != 0.0:
                work[W_LANE * BATCH + n_redo] = ln
                n_redo += 1
        for nr in range(n_redo):
            lane_law(work, int(work[W_LANE * BATCH + nr]), reach, prm, fx, False)
        cur = np.uint64(pi[first])
        acc_x = sf[cur + cur]
        acc_y = sf[cur + cur + one]
        acc_t = st[cur]
        for ln in range(m):
            kk = np.uint64(first + ln)
            if friction:  # a pair that does not touch comes back with xi = 0
                sxi[kk * hw] = work[W_XOX * BATCH + ln]
                sxi[kk * hw + one] = work[W_XOY * BATCH + ln]
            if eta:
                sxi[kk * hw + np.uint64(2)] = work[W_EOX * BATCH + ln]
                sxi[kk * hw + np.uint64(3)] = work[W_EOY * BATCH + ln]
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
        flat_ring_contacts(ps, pairs, prm, t, reach, fx)


@nb.njit(**INLINE)
def lane_law(work, lane, reach, prm, fx, defer):
    """pair_force on one lane of the work rows (see forces): forces, torques and spring written
    back there; returns ``(active, flagged)`` (flagged: deferred, redo without ``defer``)."""
    damping, friction, clip, _, _, _, window, eta = fx
    if eta and defer:  # bookkeeping, independent of the deferred branches: once per pair
        eox, eoy = pair_displacement(
            work[W_DX * BATCH + lane], work[W_DY * BATCH + lane], work[W_AI * BATCH + lane],
            work[W_AJ * BATCH + lane], work[W_DVX * BATCH + lane], work[W_DVY * BATCH + lane],
            work[W_WI * BATCH + lane], work[W_WJ * BATCH + lane], work[W_ETX * BATCH + lane],
            work[W_ETY * BATCH + lane], prm.dt)
        work[W_EOX * BATCH + lane] = eox
        work[W_EOY * BATCH + lane] = eoy
    act, fxl, fyl, til, tjl, xoxl, xoyl, again = pair_force(
        work[W_DX * BATCH + lane], work[W_DY * BATCH + lane], work[W_AI * BATCH + lane],
        work[W_AJ * BATCH + lane], work[W_DVX * BATCH + lane], work[W_DVY * BATCH + lane],
        work[W_WI * BATCH + lane], work[W_WJ * BATCH + lane], work[W_XIX * BATCH + lane],
        work[W_XIY * BATCH + lane], reach, prm, damping, friction, clip, window, defer)
    work[W_FX * BATCH + lane] = fxl
    work[W_FY * BATCH + lane] = fyl
    work[W_TI * BATCH + lane] = til
    work[W_TJ * BATCH + lane] = tjl
    work[W_XOX * BATCH + lane] = xoxl
    work[W_XOY * BATCH + lane] = xoyl
    return act, again


@nb.njit(**INLINE)
def flat_ring_contacts(ps, pairs, prm, t, reach, fx):
    """Contacts of candidate free particles with the two ring surfaces (infinitely massive)."""
    damping, friction, clip, rotation, _, _, window, eta = fx
    r_o, r_o_dot = outer_radius(t, prm)
    lim = reach if damping and window else 0.0
    for q in range(pairs.wall_count[0]):
        i = pairs.wall[q]
        rx, ry = ps.x[i, 0], ps.x[i, 1]
        r = math.sqrt(rx * rx + ry * ry)
        a = ps.radius[i]
        if prm.flat_in != 0.0 and r - prm.r_in < a + lim:  # inner: n = +e_r, speed omega_in r_in
            nx, ny, delta = rx / r, ry / r, a - (r - prm.r_in)
            vjx, vjy, s_j = 0.0, 0.0, prm.omega_in * prm.r_in
        elif prm.flat_out != 0.0 and r_o - r < a + lim:  # outer: n = -e_r, moves at r_o_dot
            nx, ny, delta = -rx / r, -ry / r, a - (r_o - r)
            vjx, vjy, s_j = -r_o_dot * nx, -r_o_dot * ny, 0.0
        else:
            if friction:
                ps.xi_wall[i, :] = 0.0
            continue
        s = (a * ps.w_pred[i] if rotation else 0.0) + s_j
        xix = ps.xi_wall[i, 0] if friction else 0.0
        xiy = ps.xi_wall[i, 1] if friction else 0.0
        wvx = ps.v_pred[i, 0] - vjx + s * ny
        wvy = ps.v_pred[i, 1] - vjy - s * nx
        fn, ftx, fty, xix, xiy, _ = contact_law(
            nx, ny, delta, wvx, wvy, xix, xiy, prm, damping, friction, clip, window)
        if friction:
            ps.xi_wall[i, 0] = xix
            ps.xi_wall[i, 1] = xiy
        if eta:
            wex, wey = 0.0, 0.0
            if delta > 0.0:
                wex, wey = tangential_displacement(ps.xi_wall[i, 2], ps.xi_wall[i, 3], nx, ny,
                                                   wvx, wvy, prm.dt)
            ps.xi_wall[i, 2] = wex
            ps.xi_wall[i, 3] = wey
        ps.f[i, 0] += fn * nx + ftx
        ps.f[i, 1] += fn * ny + fty
        if rotation:
            ps.tau[i] -= (a - 0.5 * delta) * (nx * fty - ny * ftx)


@nb.njit(**INLINE)
def kick(ps, n_move, h, prm, fx, closing):
    """Half kick of the moving particles. The closing kick of a step then applies bottom friction
    as a velocity-space Coulomb friction: it removes mu_b g dt of speed and never reverses the
    velocity, so a disk at rest stays at rest and nothing divides by zero.

    The (n, 2) arrays are read through flat views: numba indexes 2D arrays with run-time
    strides, which keeps LLVM from vectorising the loop; on flat views it does (AVX-512 square
    roots and divisions, 4x faster, same bits). Selects instead of branches for the same reason."""
    rotation, bottom = fx[3], fx[4]
    dv = prm.mu_b_g * 2.0 * h
    v, f, inv_m = ps.v.reshape(-1), ps.f.reshape(-1), ps.inv_mass
    for i in range(n_move):
        vx = v[2 * i] + h * f[2 * i] * inv_m[i]
        vy = v[2 * i + 1] + h * f[2 * i + 1] * inv_m[i]
        if bottom and closing:
            speed = math.sqrt(vx * vx + vy * vy)
            c = 1.0 - dv / speed  # inf/nan at rest: discarded by the select
            rest = speed <= dv  # false for NaN, which must reach the watchdog
            vx = 0.0 if rest else vx * c
            vy = 0.0 if rest else vy * c
        v[2 * i] = vx
        v[2 * i + 1] = vy
    if rotation:
        for i in range(n_move):
            ps.omega[i] += h * ps.tau[i] * ps.inv_inertia[i]


@nb.njit(**INLINE)
def drift(ps, clock, prm, fx, scratch):
    """Move free bodies and walls to t + dt. Returns ``(bad, disp, v2)``: the index of a
    particle that became non-finite or left the cell (-1: none), the largest displacement since
    the neighbour build plus the ring's, and the largest squared speed (m^2/s^2). ``scratch``:
    a (2, n_move) work array."""
    rotation, walls, predict = fx[3], fx[5], fx[6]
    dt = prm.dt
    h = 0.5 * dt
    n_move = clock.n_move[0]
    # a centre beyond a ring line overlaps that ring by more than a radius: it has left the cell
    # (free scenes: escape_radius = inf, nothing to leave)
    if walls:
        r_hi = outer_radius((clock.step[0] + 1) * dt, prm)[0]
        hi2, lo2 = r_hi * r_hi, prm.r_in * prm.r_in
    else:
        hi2, lo2 = prm.escape_radius * prm.escape_radius, 0.0
    # Flat views, selects and no reductions in the main loop, so that LLVM vectorises it (see
    # kick): it stores each squared speed and displacement and counts the bad centres; a
    # second, scalar loop takes the maxima.
    x, v, f, vp, xr = (ps.x.reshape(-1), ps.v.reshape(-1), ps.f.reshape(-1),
                       ps.v_pred.reshape(-1), ps.x_ref.reshape(-1))
    inv_m = ps.inv_mass
    v2, d2 = scratch[0], scratch[1]
    n_bad = 0
    for i in range(n_move):
        x0 = x[2 * i] + dt * v[2 * i]
        x1 = x[2 * i + 1] + dt * v[2 * i + 1]
        x[2 * i] = x0
        x[2 * i + 1] = x1
        if predict:
            vpx = v[2 * i] + h * f[2 * i] * inv_m[i]
            vpy = v[2 * i + 1] + h * f[2 * i + 1] * inv_m[i]
        else:
            vpx = v[2 * i]
            vpy = v[2 * i + 1]
        vp[2 * i] = vpx
        vp[2 * i + 1] = vpy
        v2[i] = vpx * vpx + vpy * vpy
        dx = x0 - xr[2 * i]
        dy = x1 - xr[2 * i + 1]
        d2[i] = dx * dx + dy * dy
        r2 = x0 * x0 + x1 * x1
        n_bad += 0 if lo2 <= r2 <= hi2 else 1  # also counts NaN
    max_d2 = 0.0
    max_v2 = 0.0
    bad = -1
    for i in range(n_move):
        max_v2 = max(max_v2, v2[i])
        max_d2 = max(max_d2, d2[i])
    if n_bad > 0:  # rare: report the last bad index
        for i in range(n_move):
            r2 = x[2 * i] * x[2 * i] + x[2 * i + 1] * x[2 * i + 1]
            if not (lo2 <= r2 <= hi2):
                bad = i
    if rotation:
        for i in range(n_move):
            ps.theta[i] += dt * ps.omega[i]
            ps.w_pred[i] = ps.omega[i] + (h * ps.tau[i] * ps.inv_inertia[i] if predict else 0.0)
    clock.step[0] += 1
    clock.phase[0] = 1
    ring_move = 0.0
    if walls:
        t = clock.step[0] * dt
        settled = outer_ring_settled(t, prm)
        place_wall_disks(ps, n_move, clock.n_moved[0], t, prm, settled)
        for i in range(n_move, clock.n_moved[0]):
            # settled outer disks: at rest at their final radius; whatever they moved since the
            # last build is in ring_move below
            if settled and ps.kind[i] == OUTER_WALL:
                continue
            vp[2 * i] = v[2 * i]  # prescribed: exact
            vp[2 * i + 1] = v[2 * i + 1]
            ps.w_pred[i] = ps.omega[i]
            max_v2 = max(max_v2, v[2 * i] ** 2 + v[2 * i + 1] ** 2)
            dx = x[2 * i] - xr[2 * i]
            dy = x[2 * i + 1] - xr[2 * i + 1]
            max_d2 = max(max_d2, dx * dx + dy * dy)
        ring_move = abs(outer_radius(t, prm)[0] - clock.r_out_ref[0])
    return bad, math.sqrt(max_d2) + ring_move, max_v2


@functools.lru_cache(maxsize=None)
def make_stepper(opts: StepOptions) -> Stepper:
    """Compile (or load from numba's cache) the step loop for one set of effects."""
    if opts.eta and not opts.law.friction:
        raise ValueError("StepOptions: eta is tracked only with tangential friction")
    fx = (opts.law.damping, opts.law.friction, opts.law.clip, opts.rotation,
          opts.bottom_friction, opts.walls, opts.predict, opts.eta)

    @nb.njit(**JIT)
    def advance(ps, pairs, clock, prm, halo, target):
        h = 0.5 * prm.dt
        n_move = clock.n_move[0]
        n_all = clock.n_local[0] + clock.n_ghost[0]
        scratch = np.empty((2, n_move))
        work = np.zeros(WORK_ROWS * BATCH)
        while clock.step[0] < target or clock.phase[0] == 1:
            if clock.phase[0] == 0:
                kick(ps, n_move, h, prm, fx, False)
                bad, disp, v2 = drift(ps, clock, prm, fx, scratch)
                # ghosts to t + dt; every rank learns the global maxima (one rank: no-op)
                err, bad_any, disp, v2 = refresh_ghosts(ps, halo, clock.n_local[0], bad >= 0,
                                                        disp, v2, clock.step[0])
                if err != 0:
                    return MPI_FAILED, -1
                if bad_any:
                    return BAD_PARTICLE, bad
                clock.reach[0] = math.sqrt(v2) * prm.dt  # 2 max|v| dt/2
                # the list must hold every pair within reach of touching:
                # 2 max_disp + reach <= skin
                if disp + 0.5 * clock.reach[0] > 0.5 * prm.skin:
                    clock.disp[0] = disp
                    return NEED_REBUILD, -1
            forces(ps, pairs, n_all, prm, clock.step[0] * prm.dt, clock.reach[0], fx, work)
            kick(ps, n_move, h, prm, fx, True)
            clock.phase[0] = 0
        return OK, -1

    @nb.njit(**JIT)
    def compute_forces(ps, pairs, clock, prm, v2):
        """Forces of the current state with synchronous velocities (start of a run); v2 is the
        largest squared speed over all ranks (m^2/s^2). Ghost velocities must be current."""
        n = clock.n_local[0] + clock.n_ghost[0]
        ps.v_pred[:n] = ps.v[:n]
        ps.w_pred[:n] = ps.omega[:n]
        clock.reach[0] = math.sqrt(v2) * prm.dt
        forces(ps, pairs, n, prm, clock.step[0] * prm.dt, clock.reach[0], fx,
               np.zeros(WORK_ROWS * BATCH))

    return Stepper(advance=advance, compute_forces=compute_forces)

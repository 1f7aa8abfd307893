"""Velocity-Verlet half steps: the kick (velocities from forces, then bottom friction) and the
drift (positions, the rings and their wall disks, the predicted velocities), fused with the
opening kick and the previous step's closing kick into one pass (kick_drift).

Stage: integration (inside the step loop, ``step.py``). Reads and writes the moving bodies'
rows of ``Particles`` (the free particles this rank owns, then the wall disks near its sector)
and the ``Clock``. ``opts`` is a ``step.StepOptions``: its switches are compile-time constants.
"""

from __future__ import annotations

import math

import numba as nb

from .jit import INLINE
from .state import OUTER_WALL
from ..boundaries.walls import outer_radius, outer_ring_settled, place_wall_disks


@nb.njit(**INLINE)
def closing_velocity(vx, vy, dv, opts):
    """A closing kick's velocity after bottom friction (when on), which removes dv = mu_b g dt
    of speed and never reverses it: a disk at rest stays at rest, nothing divides by zero."""
    if not opts.bottom_friction:
        return vx, vy
    speed = math.sqrt(vx * vx + vy * vy)
    c = 1.0 - dv / speed  # inf/nan at rest: discarded by the select
    rest = speed <= dv  # false for NaN, which must reach the watchdog
    return (0.0 if rest else vx * c), (0.0 if rest else vy * c)


@nb.njit(**INLINE)
def kick(ps, n_owned, h, prm, opts, closing):
    """Half kick of the moving particles; a closing kick then applies bottom friction as a
    velocity-space Coulomb friction (closing_velocity). The step loop calls it for the last
    step of a call only: otherwise kick_drift does it.

    The (n, 2) arrays are read through flat views: numba indexes 2D arrays with run-time
    strides, which keeps LLVM from vectorising the loop; on flat views it does (AVX-512 square
    roots and divisions, 4x faster, same bits). Selects instead of branches for the same reason."""
    dv = prm.mu_b_g * 2.0 * h
    v, f, inv_m = ps.v.reshape(-1), ps.f.reshape(-1), ps.inv_mass
    for i in range(n_owned):
        vx = v[2 * i] + h * f[2 * i] * inv_m[i]
        vy = v[2 * i + 1] + h * f[2 * i + 1] * inv_m[i]
        if closing:
            vx, vy = closing_velocity(vx, vy, dv, opts)
        v[2 * i] = vx
        v[2 * i + 1] = vy
    if opts.rotation:
        for i in range(n_owned):
            ps.omega[i] += h * ps.tau[i] * ps.inv_inertia[i]


PEAK_LANES = 8  # partial maxima of kick_drift's peaks: independent chains, one vector


@nb.njit(**INLINE)
def kick_drift(ps, clock, prm, opts, peaks, close):
    """Move free bodies and walls to t + dt in one pass over the free particles: the previous
    step's closing kick when ``close`` (the step loop defers it while it goes on), the opening
    half kick, the drift and the predicted velocities; then the walls. Each velocity gets the
    same additions in the same order as kick(closing), kick, drift in turn: the same bits, one
    pass over the particles' rows instead of three. Returns ``(bad, disp, v2)``: the index of
    a particle that became non-finite or left the cell (-1: none), the largest displacement of
    a free particle since the neighbour build plus the outer ring's, and the largest squared
    speed of any body (m^2/s^2). The wall disks' displacement is a function of time alone
    (``wall_travel``). ``peaks``: a (2, PEAK_LANES) work array."""
    dt = prm.dt
    h = 0.5 * dt
    dv = prm.mu_b_g * 2.0 * h  # as kick's
    n_owned = clock.n_owned[0]
    # a centre beyond a ring line overlaps that ring by more than a radius: it has left the cell
    # (free scenes: escape_radius = inf, nothing to leave)
    if opts.walls:
        r_hi = outer_radius((clock.step[0] + 1) * dt, prm.rings)[0]
        hi2, lo2 = r_hi * r_hi, prm.rings.r_in * prm.rings.r_in
    else:
        hi2, lo2 = prm.escape_radius * prm.escape_radius, 0.0
    # Flat views, selects and no reductions but a count in the main loop, so that LLVM
    # vectorises it (see kick); it writes three arrays only: each more costs the vector loop
    # a run-time alias check, and with two more (the squared speeds and displacements for the
    # maxima) the fused loop ran at scalar speed. The maxima take a second loop.
    x, v, f, vp = ps.x.reshape(-1), ps.v.reshape(-1), ps.f.reshape(-1), ps.v_pred.reshape(-1)
    inv_m = ps.inv_mass
    n_bad = 0
    for i in range(n_owned):
        ax = h * f[2 * i] * inv_m[i]
        ay = h * f[2 * i + 1] * inv_m[i]
        vx = v[2 * i]
        vy = v[2 * i + 1]
        if close:
            vx, vy = closing_velocity(vx + ax, vy + ay, dv, opts)
        vx = vx + ax
        vy = vy + ay
        v[2 * i] = vx
        v[2 * i + 1] = vy
        x0 = x[2 * i] + dt * vx
        x1 = x[2 * i + 1] + dt * vy
        x[2 * i] = x0
        x[2 * i + 1] = x1
        vp[2 * i] = vx + ax if opts.predict else vx
        vp[2 * i + 1] = vy + ay if opts.predict else vy
        r2 = x0 * x0 + x1 * x1
        n_bad += 0 if lo2 <= r2 <= hi2 else 1  # also counts NaN
    max_v2, max_d2 = free_peaks(ps, n_owned, peaks)
    bad = -1
    if n_bad > 0:  # rare: report the last bad index
        for i in range(n_owned):
            r2 = x[2 * i] * x[2 * i] + x[2 * i + 1] * x[2 * i + 1]
            if not (lo2 <= r2 <= hi2):
                bad = i
    if opts.rotation:
        for i in range(n_owned):
            b = h * ps.tau[i] * ps.inv_inertia[i]
            w = ps.omega[i] + b if close else ps.omega[i]
            w = w + b
            ps.omega[i] = w
            ps.theta[i] += dt * w
            ps.w_pred[i] = w + (b if opts.predict else 0.0)
    clock.step[0] += 1
    clock.phase[0] = 1
    ring_move = 0.0
    if opts.walls:
        t = clock.step[0] * dt
        settled = outer_ring_settled(t, dt, prm.rings)
        place_wall_disks(ps, n_owned, clock.n_moving[0], t, prm.rings, settled)  # with v_pred
        for i in range(n_owned, clock.n_moving[0]):
            # settled outer disks: at rest at their final radius; whatever they moved since the
            # last build is in ring_move below
            if settled and ps.kind[i] == OUTER_WALL:
                continue
            max_v2 = max(max_v2, v[2 * i] ** 2 + v[2 * i + 1] ** 2)
        ring_move = abs(outer_radius(t, prm.rings)[0] - clock.r_out_ref[0])
    return bad, math.sqrt(max_d2) + ring_move, max_v2


@nb.njit(**INLINE)
def free_peaks(ps, n_owned, peaks):
    """(largest squared predicted speed, largest squared displacement since the neighbour
    build) of the free particles, in PEAK_LANES independent running maxima (one chain of
    dependent maxima cost twice as much): the maximum does not depend on the order, so the
    bits are those of one chain. A NaN is not carried, but it also made a position NaN,
    which kick_drift reports."""
    x, vp, xr = ps.x.reshape(-1), ps.v_pred.reshape(-1), ps.x_ref.reshape(-1)
    mv, md = peaks[0], peaks[1]
    mv[:] = 0.0
    md[:] = 0.0
    n_lanes = n_owned - n_owned % PEAK_LANES
    for i0 in range(0, n_lanes, PEAK_LANES):
        for ln in range(PEAK_LANES):
            a, b = speed_and_move(x, vp, xr, i0 + ln)
            mv[ln] = a if a > mv[ln] else mv[ln]
            md[ln] = b if b > md[ln] else md[ln]
    for i in range(n_lanes, n_owned):
        a, b = speed_and_move(x, vp, xr, i)
        mv[0] = a if a > mv[0] else mv[0]
        md[0] = b if b > md[0] else md[0]
    return mv.max(), md.max()


@nb.njit(**INLINE)
def speed_and_move(x, vp, xr, i):
    """(squared predicted speed, squared displacement since the build) of particle i, from the
    flat views of x, v_pred and x_ref."""
    dx = x[2 * i] - xr[2 * i]
    dy = x[2 * i + 1] - xr[2 * i + 1]
    return vp[2 * i] * vp[2 * i] + vp[2 * i + 1] * vp[2 * i + 1], dx * dx + dy * dy


@nb.njit(**INLINE)
def wall_travel(clock, prm):
    """Bound (m) on how far any wall disk moved since the last neighbour build: the chord of
    the inner ring's turn plus the outer ring's radial move. A function of the steps and the
    rings alone, so every rank computes the same bits."""
    half_turn = 0.5 * prm.rings.omega_in * (clock.step[0] - clock.step_ref[0]) * prm.dt
    chord = 2.0 * prm.rings.r_in * (
        abs(math.sin(half_turn)) if abs(half_turn) < 0.5 * math.pi else 1.0) \
        if prm.inner_disks else 0.0
    r_o = outer_radius(clock.step[0] * prm.dt, prm.rings)[0]
    return chord + abs(r_o - clock.r_out_ref[0])

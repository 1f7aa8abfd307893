"""Velocity-Verlet half steps: the kick (velocities from forces, then bottom friction) and the
drift (positions, the rings and their wall disks, the predicted velocities).

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
def kick(ps, n_owned, h, prm, opts, closing):
    """Half kick of the moving particles. The closing kick of a step then applies bottom friction
    as a velocity-space Coulomb friction: it removes mu_b g dt of speed and never reverses the
    velocity, so a disk at rest stays at rest and nothing divides by zero.

    The (n, 2) arrays are read through flat views: numba indexes 2D arrays with run-time
    strides, which keeps LLVM from vectorising the loop; on flat views it does (AVX-512 square
    roots and divisions, 4x faster, same bits). Selects instead of branches for the same reason."""
    dv = prm.mu_b_g * 2.0 * h
    v, f, inv_m = ps.v.reshape(-1), ps.f.reshape(-1), ps.inv_mass
    for i in range(n_owned):
        vx = v[2 * i] + h * f[2 * i] * inv_m[i]
        vy = v[2 * i + 1] + h * f[2 * i + 1] * inv_m[i]
        if opts.bottom_friction and closing:
            speed = math.sqrt(vx * vx + vy * vy)
            c = 1.0 - dv / speed  # inf/nan at rest: discarded by the select
            rest = speed <= dv  # false for NaN, which must reach the watchdog
            vx = 0.0 if rest else vx * c
            vy = 0.0 if rest else vy * c
        v[2 * i] = vx
        v[2 * i + 1] = vy
    if opts.rotation:
        for i in range(n_owned):
            ps.omega[i] += h * ps.tau[i] * ps.inv_inertia[i]


@nb.njit(**INLINE)
def drift(ps, clock, prm, opts, scratch):
    """Move free bodies and walls to t + dt. Returns ``(bad, disp, v2)``: the index of a
    particle that became non-finite or left the cell (-1: none), the largest displacement of a
    free particle since the neighbour build plus the outer ring's, and the largest squared
    speed of any body (m^2/s^2). The wall disks' displacement is a function of time alone
    (``wall_travel``). ``scratch``: a (2, n_owned) work array."""
    dt = prm.dt
    h = 0.5 * dt
    n_owned = clock.n_owned[0]
    # a centre beyond a ring line overlaps that ring by more than a radius: it has left the cell
    # (free scenes: escape_radius = inf, nothing to leave)
    if opts.walls:
        r_hi = outer_radius((clock.step[0] + 1) * dt, prm.rings)[0]
        hi2, lo2 = r_hi * r_hi, prm.rings.r_in * prm.rings.r_in
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
    for i in range(n_owned):
        x0 = x[2 * i] + dt * v[2 * i]
        x1 = x[2 * i + 1] + dt * v[2 * i + 1]
        x[2 * i] = x0
        x[2 * i + 1] = x1
        if opts.predict:
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
    for i in range(n_owned):
        max_v2 = max(max_v2, v2[i])
        max_d2 = max(max_d2, d2[i])
    if n_bad > 0:  # rare: report the last bad index
        for i in range(n_owned):
            r2 = x[2 * i] * x[2 * i] + x[2 * i + 1] * x[2 * i + 1]
            if not (lo2 <= r2 <= hi2):
                bad = i
    if opts.rotation:
        for i in range(n_owned):
            ps.theta[i] += dt * ps.omega[i]
            ps.w_pred[i] = ps.omega[i] + (h * ps.tau[i] * ps.inv_inertia[i] if opts.predict
                                          else 0.0)
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

"""The contact law of SPEC §3 (paper eqs. 1.1-1.4), specialised on the scene's effects.

Stage: force kernels. ``contact_law`` and ``pair_force`` are stateless jitted functions that the
step loop inlines; their last arguments are the effect switches (damping, friction, clip,
window: the damping weight at contact entry and exit, part of the default integrator) and
``defer`` (the batched pair loop's SIMD pass). The step loop passes compile-time constants
there, so a disabled effect is removed by the compiler (no branch per contact, no history
access). Keeping these module-level (not closures) lets numba's on-disk cache serve them to
every later process.

Conventions (shared with the averaging package):
- n points from partner j to particle i; overlap delta = a_i + a_j - |r_i - r_j| > 0.
- v_ij is the relative velocity of the contact point,
  v_ij = (v_i - v_j) - (a_i w_i + a_j w_j) z x n; the normal overlap rate is delta_dot = -v_ij . n.
- normal force on i: f_n n with f_n = k_n delta + gamma_n delta_dot (eqs. 1.1, 1.2).
- tangential spring xi (m) lies in the tangent plane; trial force f_t = -k_t xi, capped at
  mu |f_n| (eq. 1.4); when sliding, xi is rescaled so that k_t |xi| = mu |f_n|.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb

from .jit import INLINE


class LawOptions(NamedTuple):
    """Which terms of the contact law are compiled in (hashable, so factories can cache)."""

    damping: bool = True
    friction: bool = True
    clip: bool = False


@nb.njit(**INLINE)
def contact_law(nx, ny, delta, vx, vy, xix, xiy, prm, damping, friction, clip, window,
                defer=False):
    """``-> (fn, ftx, fty, xix, xiy, sliding)`` for a contact with normal (nx, ny), overlap
    delta (m) and relative contact velocity v_ij = (vx, vy) (m/s); (xix, xiy) is the spring
    before this step, the one returned is updated (rotated into the current tangent plane,
    incremented by v_ij^t dt, capped). delta <= 0 is allowed (a pair within half a step of
    touching): it gets only its share of the damping force, no elastic force and no spring.
    Without ``window`` the damping acts in full while delta > 0 (plain velocity Verlet).

    ``defer`` (for the batched pair loop): skip the two rare branches, the partial damping
    window and the Coulomb cap, which need divisions and a square root. If either was needed,
    ``sliding`` comes back True and the results are unfinished: the caller must redo this
    contact with ``defer=False``. Every other contact gets the same bits either way."""
    vn = vx * nx + vy * ny  # = -delta_dot
    redo = False
    fn = prm.k_n * delta if delta > 0.0 else 0.0
    if damping and not window:
        fn -= prm.gamma_n * vn if delta > 0.0 else 0.0
    elif damping:
        # Velocity Verlet applies each force sample for one window [t - dt/2, t + dt/2]. The
        # damping term jumps at contact entry and exit, so weight it by the in-contact
        # fraction of the window; otherwise e_n carries an O(dt) error that depends on where
        # the contact begins and ends between steps (up to 6 % at dt = t_c/50).
        w = 1.0
        half = 0.5 * abs(vn) * prm.dt  # overlap change over half a step
        if delta < half:
            if defer:
                redo = True
            else:
                w = max(0.5 + 0.5 * delta / half, 0.0) if half > 0.0 else 0.0
        fn -= w * prm.gamma_n * vn
    if clip:
        fn = max(fn, 0.0)
    ftx = 0.0
    fty = 0.0
    sliding = False
    if friction:
        if delta <= 0.0:  # within reach of a contact, not touching: no spring
            return fn, 0.0, 0.0, 0.0, 0.0, redo
        # Keep the spring in the tangent plane as the contact rotates (projection).
        xn = xix * nx + xiy * ny
        xix = xix - xn * nx + (vx - vn * nx) * prm.dt
        xiy = xiy - xn * ny + (vy - vn * ny) * prm.dt
        ftx = -prm.k_t * xix
        fty = -prm.k_t * xiy
        fmax = prm.mu * abs(fn)
        ft2 = ftx * ftx + fty * fty
        if ft2 > fmax * fmax and defer:
            redo = True
        elif ft2 > fmax * fmax:
            cap = fmax / math.sqrt(ft2)
            ftx *= cap
            fty *= cap
            xix = -ftx / prm.k_t
            xiy = -fty / prm.k_t
            sliding = True
    return fn, ftx, fty, xix, xiy, sliding or redo


@nb.njit(**INLINE)
def tangential_displacement(ex, ey, nx, ny, vx, vy, dt):
    """The paper's eta (eq. 1.3) after one step: the previous (ex, ey) projected into the
    current tangent plane (normal (nx, ny)) plus v_ij^t dt, with v_ij = (vx, vy). The same
    arithmetic as the spring's update in ``contact_law`` but never capped, so eta equals the
    spring bit for bit until the contact first slides, and keeps growing while it slides.
    Bookkeeping for averaging and output: no force depends on it. (Local names differ from
    the callers' and contact_law's: see jit.py on inlining.)"""
    td_vn = vx * nx + vy * ny
    td_en = ex * nx + ey * ny
    return ex - td_en * nx + (vx - td_vn * nx) * dt, ey - td_en * ny + (vy - td_vn * ny) * dt


@nb.njit(**INLINE)
def pair_displacement(dx, dy, ai, aj, dvx, dvy, wi, wj, ex, ey, dt):
    """``tangential_displacement`` of a disk-disk pair from pair_force's inputs, with
    pair_force's geometry; (0, 0) unless the disks overlap (a new contact starts from zero,
    like the spring). Selects, not branches, so that the batched pair loop stays vectorised."""
    pd_dist = math.sqrt(dx * dx + dy * dy)
    pd_inv = 1.0 / pd_dist
    pd_nx = dx * pd_inv
    pd_ny = dy * pd_inv
    pd_s = ai * wi + aj * wj
    pd_ex, pd_ey = tangential_displacement(ex, ey, pd_nx, pd_ny, dvx + pd_s * pd_ny,
                                           dvy - pd_s * pd_nx, dt)
    pd_on = ai + aj - pd_dist > 0.0
    return (pd_ex if pd_on else 0.0), (pd_ey if pd_on else 0.0)


@nb.njit(**INLINE)
def pair_force(dx, dy, ai, aj, dvx, dvy, wi, wj, xix, xiy, reach, prm, damping, friction, clip,
               window, defer=False):
    """Disk-disk contact. (dx, dy) = r_i - r_j, (dvx, dvy) = v_i - v_j, wi, wj spins; reach (m)
    bounds how far any overlap can change in half a step (pairs that close get their share of
    damping). Returns ``(active, fx, fy, tau_i, tau_j, xix, xiy, sliding)``: force on i (j gets
    -f), torques on i and j, and contact_law's flag (with ``defer``: redo this pair without).
    Swapping i and j negates the force bit for bit (every operation is odd
    in the swap)."""
    r2 = dx * dx + dy * dy
    rs = ai + aj
    lim = rs + reach if damping and window else rs
    if r2 >= lim * lim:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False
    dist = math.sqrt(r2)
    inv = 1.0 / dist
    nx = dx * inv
    ny = dy * inv
    delta = rs - dist
    s = ai * wi + aj * wj
    # v_ij = dv - s (z x n), with z x n = (-ny, nx)
    fn, ftx, fty, xix, xiy, flag = contact_law(nx, ny, delta, dvx + s * ny, dvy - s * nx, xix,
                                               xiy, prm, damping, friction, clip, window, defer)
    # torque of f_t about each centre, lever (a - delta/2) along -n for i and +n for j
    nxft = nx * fty - ny * ftx
    return (True, fn * nx + ftx, fn * ny + fty, -(ai - 0.5 * delta) * nxft,
            -(aj - 0.5 * delta) * nxft, xix, xiy, flag)

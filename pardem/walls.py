"""Couette boundaries: prescribed motion of the two rings and their glued wall disks.

Stage: boundaries. The inner ring (radius r_in) turns counter-clockwise at omega_in from t = 0.
The outer ring shrinks from r_out0 to r_out during [0, t_comp] with a cosine ramp (zero speed at
both ends, so the packing is not jolted when the wall stops), then stays fixed.
Wall disks (d = 2.5 mm by default) sit with their centres on the ring lines, evenly spaced;
they are infinitely massive bodies that move with their ring.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .jit import JIT
from .sectors import near
from .state import INNER_WALL, pack_particles, unpack_particles


@nb.njit(**JIT)
def outer_radius(t, prm):
    """Outer ring radius (m) and its rate (m/s) at time t (s)."""
    if t >= prm.t_comp or prm.t_comp <= 0.0:
        return prm.r_out, 0.0
    c = 0.5 * (1.0 + math.cos(math.pi * t / prm.t_comp))
    rate = -0.5 * math.pi / prm.t_comp * math.sin(math.pi * t / prm.t_comp)
    return prm.r_out + (prm.r_out0 - prm.r_out) * c, (prm.r_out0 - prm.r_out) * rate


@nb.njit(**JIT)
def outer_ring_settled(t, prm):
    """True at time t (s) if the outer ring's disks already sit at rest at their final radius:
    the step loop placed them at an earlier step after the compression (t - 2 dt >= t_comp:
    one step of slack against rounding of t; it also means step >= 2, so that earlier placement
    was the loop's, not the initial layout's). Placing them again would write the same bits."""
    return t - 2.0 * prm.dt >= prm.t_comp


@nb.njit(**JIT)
def place_wall_disks(ps, first, last, t, prm, settled):
    """Set position, velocity and spin of wall disks ps[first:last] at time t (an exact function
    of t and the disk's unit vector e0, so every rank and every restart gets the same bits).
    ``settled`` (outer_ring_settled): skip the outer ring's disks, which would not change."""
    r_o, r_o_dot = outer_radius(t, prm)
    c, s = math.cos(prm.omega_in * t), math.sin(prm.omega_in * t)
    for k in range(first, last):
        ex, ey = ps.e0[k, 0], ps.e0[k, 1]
        if ps.kind[k] == INNER_WALL:  # rotate e0 by omega_in t
            ux = ex * c - ey * s
            uy = ey * c + ex * s
            ps.x[k, 0] = prm.r_in * ux
            ps.x[k, 1] = prm.r_in * uy
            ps.v[k, 0] = -prm.omega_in * prm.r_in * uy
            ps.v[k, 1] = prm.omega_in * prm.r_in * ux
            ps.omega[k] = prm.omega_in  # glued: turns with the ring
            ps.theta[k] = prm.omega_in * t
        elif not settled:
            ps.x[k, 0] = r_o * ex
            ps.x[k, 1] = r_o * ey
            ps.v[k, 0] = r_o_dot * ex
            ps.v[k, 1] = r_o_dot * ey
            ps.omega[k] = 0.0


@nb.njit(**JIT)
def arrange_walls(ps, first, first_idle, end, t, prm, edges, rank, margin, width):
    """Under MPI, at an exchange: place the idle wall disks ps[first_idle:end] at time t (the
    step loop moved only ps[first:first_idle]), then store the wall disks ps[first:end] that are
    within ``margin`` (m) of sector ``rank`` (edges: the sector edges, rad) or inside it first.
    Returns how many that is. ``width``: columns of a packed row. One compiled call: at an
    exchange, every call from Python that passes the particle arrays costs tens of us."""
    place_wall_disks(ps, first_idle, end, t, prm, False)
    close = near(ps.x[first:end], edges, rank, margin)
    n_near = int(close.sum())
    if not close[:n_near].all():  # not yet stored near-first
        order = np.concatenate((np.flatnonzero(close), np.flatnonzero(~close))) + first
        rows = np.empty((order.size, width))
        pack_particles(ps, order, rows)
        unpack_particles(rows, ps, first)
    return n_near


def wall_disk_angles(radius: float, spacing: float) -> np.ndarray:
    """Evenly spaced angles (rad) for disks along a ring, about ``spacing`` (m) apart."""
    n = max(int(round(2.0 * math.pi * radius / spacing)), 1)
    return 2.0 * math.pi * np.arange(n) / n

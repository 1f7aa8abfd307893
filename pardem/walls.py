"""Couette boundaries: prescribed motion of the two rings and their glued wall disks.

Stage: boundaries. The inner ring (radius r_in) turns counter-clockwise at omega_in from t = 0.
The outer ring shrinks from r_out0 to r_out during [0, t_comp] with a cosine ramp (zero speed at
both ends, so the packing is not jolted when the wall stops), then stays fixed.
Wall disks (d = 2.5 mm by default) sit with their centres on the ring lines, evenly spaced, in a
per-ring layout (``WallLayout``: count, diameter, whether the flat ring surface behind them is a
contact surface); they are infinitely massive bodies that move with their ring.
"""

from __future__ import annotations

import math
from typing import NamedTuple

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


class WallLayout(NamedTuple):
    """The roughness of one ring: ``count`` glued disks (0: a smooth ring) of ``diameter`` (m)
    with their centres evenly spaced on the ring line at ``radius`` (m; the outer ring's final
    radius), and whether the flat ring surface behind them is a contact surface (``flat``)."""

    count: int
    diameter: float
    flat: bool
    radius: float


MAX_DISKS_PER_DIAMETER = 100  # more wall disks than this along one disk diameter: refused


def wall_layout(g, ring: str) -> WallLayout:
    """The layout of ring "inner" or "outer" of a scene's Geometry, with its defaults resolved:
    the count from wall_particle_spacing, the diameter from wall_particle_diameter."""
    radius = g.inner_radius if ring == "inner" else g.outer_radius
    count = getattr(g, f"{ring}_wall_count")
    if count is None:
        count = max(int(round(2.0 * math.pi * radius / g.wall_particle_spacing)), 1)
    diameter = getattr(g, f"{ring}_wall_diameter") or g.wall_particle_diameter
    return WallLayout(count, diameter, getattr(g, f"{ring}_flat_surface"), radius)


def check_layout(g, ring: str, smallest_free: float):
    """Why ring's layout cannot hold the free disks (smallest diameter ``smallest_free``, m),
    as ``(key, value, reason)``, or None if it can. Without the flat surface the disks alone
    must keep every free disk in the cell: the gap between neighbours, at the largest radius
    they reach (the outer ring starts extended), must be narrower than the smallest free disk."""
    w = wall_layout(g, ring)
    if w.count > MAX_DISKS_PER_DIAMETER * 2.0 * math.pi * w.radius / w.diameter:
        return (f"{ring}_wall_count", w.count, f"more than {MAX_DISKS_PER_DIAMETER} disks per "
                f"wall-disk diameter along the ring (circumference {2 * math.pi * w.radius:.6g} m"
                f", diameter {w.diameter!r} m)")
    if not w.diameter < g.outer_radius - g.inner_radius:
        return (f"{ring}_wall_diameter", w.diameter,
                f"must be < outer_radius - inner_radius = {g.outer_radius - g.inner_radius:.6g} m")
    if w.flat:
        return None
    if w.count == 0:
        return (f"{ring}_flat_surface", False, f"a ring with {ring}_wall_count = 0 (smooth) needs "
                "its flat surface, or the free disks would leave the cell through it")
    widest = g.outer_start_radius if ring == "outer" else g.inner_radius
    gap = 2.0 * widest * math.sin(math.pi / w.count) - w.diameter if w.count > 1 else math.inf
    if gap >= smallest_free:
        return (f"{ring}_flat_surface", False, f"without the flat surface the {w.count} wall "
                f"disks leave gaps of {gap:.6g} m (at radius {widest!r} m), wide enough for the "
                f"smallest free disk ({smallest_free!r} m) to pass; use more wall disks or keep "
                "the flat surface")
    return None


def wall_disk_angles(count: int) -> np.ndarray:
    """Angles (rad) of ``count`` disks evenly spaced along a ring, the first at angle 0."""
    return 2.0 * math.pi * np.arange(count) / count if count else np.zeros(0)

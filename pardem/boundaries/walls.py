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

from .protocol import NO_DISKS, Boundary, Glued
from ..core.jit import INLINE, JIT
from ..core.state import INNER_WALL, OUTER_WALL


class Rings(NamedTuple):
    """The two rings of a Couette scene (SI): r_in (m) and omega_in (rad/s, counter-clockwise
    positive) of the inner ring; r_out (m, final), r_out0 (m, at t = 0) and t_comp (s, the
    compression time) of the outer ring; flat_in, flat_out: whether the flat ring surface is a
    contact surface (else only its wall disks are: ``WallLayout.flat``); phase_in (rad): the
    inner ring's angle is omega_in t + phase_in (0 but in a branch whose omega_in differs from
    the prepared run's, which keeps the angle the ring had turned: output/branch.py)."""

    r_in: float = 0.0
    omega_in: float = 0.0
    r_out: float = 0.0
    r_out0: float = 0.0
    t_comp: float = 0.0
    flat_in: bool = True
    flat_out: bool = True
    phase_in: float = 0.0


def rings_of(g) -> Rings:
    """Rings of a scene's Geometry (None: a free scene, no rings)."""
    if g is None:
        return Rings()
    return Rings(g.inner_radius, g.omega_inner, g.outer_radius, g.outer_start_radius,
                 g.compression_time, wall_layout(g, "inner").flat, wall_layout(g, "outer").flat)


@nb.njit(**JIT)
def outer_radius(t, rings):
    """Outer ring radius (m) and its rate (m/s) at time t (s)."""
    if t >= rings.t_comp or rings.t_comp <= 0.0:
        return rings.r_out, 0.0
    c = 0.5 * (1.0 + math.cos(math.pi * t / rings.t_comp))
    rate = -0.5 * math.pi / rings.t_comp * math.sin(math.pi * t / rings.t_comp)
    return rings.r_out + (rings.r_out0 - rings.r_out) * c, (rings.r_out0 - rings.r_out) * rate


@nb.njit(**JIT)
def outer_ring_settled(t, dt, rings):
    """True at time t (s) if the outer ring's disks already sit at rest at their final radius:
    the step loop placed them at an earlier step after the compression (t - 2 dt >= t_comp:
    one step of slack against rounding of t; it also means step >= 2, so that earlier placement
    was the loop's, not the initial layout's). Placing them again would write the same bits."""
    return t - 2.0 * dt >= rings.t_comp


@nb.njit(**JIT)
def place_wall_disks(ps, first, last, t, rings, settled):
    """Set position, velocity and spin of wall disks ps[first:last] at time t (an exact function
    of t and the disk's unit vector e0, so every rank and every restart gets the same bits),
    and their predicted velocity and spin, which the forces read: prescribed, they are exact.
    Under MPI a rank places the disks far from its domain only at exchanges; one that comes
    near after a re-cut is touched at once, so its prediction must be current too.
    ``settled`` (outer_ring_settled): skip the outer ring's disks, which would not change.
    The disks of any other boundary do not move: they keep the place and the zero velocity
    they were given at set-up (registry.py)."""
    r_o, r_o_dot = outer_radius(t, rings)
    angle = rings.omega_in * t
    if rings.phase_in != 0.0:  # only then: omega t + 0.0 would turn a -0.0 into +0.0
        angle += rings.phase_in
    c, s = math.cos(angle), math.sin(angle)
    for k in range(first, last):
        ex, ey = ps.e0[k, 0], ps.e0[k, 1]
        kind = ps.kind[k]
        if kind == INNER_WALL:  # rotate e0 by the ring's angle
            ux = ex * c - ey * s
            uy = ey * c + ex * s
            ps.x[k, 0] = rings.r_in * ux
            ps.x[k, 1] = rings.r_in * uy
            ps.v[k, 0] = -rings.omega_in * rings.r_in * uy
            ps.v[k, 1] = rings.omega_in * rings.r_in * ux
            ps.omega[k] = rings.omega_in  # glued: turns with the ring
            ps.theta[k] = angle
            ps.w_pred[k] = rings.omega_in
        elif kind == OUTER_WALL and not settled:
            ps.x[k, 0] = r_o * ex
            ps.x[k, 1] = r_o * ey
            ps.v[k, 0] = r_o_dot * ex
            ps.v[k, 1] = r_o_dot * ey
            ps.omega[k] = 0.0
            ps.w_pred[k] = 0.0
        else:
            continue
        ps.v_pred[k, 0] = ps.v[k, 0]
        ps.v_pred[k, 1] = ps.v[k, 1]


class SurfaceHit(NamedTuple):
    """A disk against the flat ring surfaces (``ring_surface``): ring 0 (none), 1 (inner) or 2
    (outer), the unit normal (nx, ny) from the surface to the disk and the overlap delta (m)."""

    ring: int
    nx: float
    ny: float
    delta: float


@nb.njit(**INLINE)
def ring_surface(rx, ry, a, lim, r_o, rings):
    """The SurfaceHit of a disk of radius a at (rx, ry), counted as touching within ``lim``
    (m); r_o: the outer radius now (outer_radius). A ring without its flat surface is never
    touched; a disk cannot touch both."""
    rs_r = math.sqrt(rx * rx + ry * ry)
    if rings.flat_in and rs_r - rings.r_in < a + lim:  # n = +e_r
        return SurfaceHit(1, rx / rs_r, ry / rs_r, a - (rs_r - rings.r_in))
    if rings.flat_out and r_o - rs_r < a + lim:  # n = -e_r
        return SurfaceHit(2, -rx / rs_r, -ry / rs_r, a - (r_o - rs_r))
    return SurfaceHit(0, 0.0, 0.0, 0.0)


@nb.njit(**INLINE)
def surface_motion(hit, r_o_dot, rings):
    """``(vx, vy, s, spin)`` of the surface a disk touches (``hit``, ring 1 or 2): the velocity
    (m/s) of its centre line, its turning speed s = radius x spin (m/s; the contact point moves
    at (vx, vy) + s z x n, as a disk of that radius would) and its spin (rad/s). The inner ring
    turns at omega_in; the outer one moves radially at r_o_dot (outer_radius)."""
    if hit.ring == 1:
        return 0.0, 0.0, rings.omega_in * rings.r_in, rings.omega_in
    return -r_o_dot * hit.nx, -r_o_dot * hit.ny, 0.0, 0.0


class WallLayout(NamedTuple):
    """The roughness of one ring: ``count`` glued disks (0: a smooth ring) of ``diameter`` (m)
    with their centres evenly spaced on the ring line at ``radius`` (m; the outer ring's final
    radius), and whether the flat ring surface behind them is a contact surface (``flat``)."""

    count: int
    diameter: float
    flat: bool
    radius: float


MAX_DISKS_PER_DIAMETER = 100  # more wall disks than this along one disk diameter: refused
MAX_WALL_DISKS = 1_000_000  # per ring (9e6 disks of 0.1 um stalled the first neighbour build)


def wall_layout(g, ring: str) -> WallLayout:
    """The layout of ring "inner" or "outer" of a scene's Geometry, with its defaults resolved:
    the count from wall_particle_spacing, the diameter from wall_particle_diameter."""
    radius = g.inner_radius if ring == "inner" else g.outer_radius
    count = getattr(g, f"{ring}_wall_count")
    if count is None:
        count = max(int(round(2.0 * math.pi * radius / g.wall_particle_spacing)), 1)
    diameter = getattr(g, f"{ring}_wall_diameter") or g.wall_particle_diameter
    return WallLayout(count, diameter, getattr(g, f"{ring}_flat_surface"), radius)


def wall_area_share(g) -> float:
    """Area (m^2) the wall disks add to the paper's global volume fraction: half of each."""
    return sum(0.5 * w.count * math.pi * w.diameter**2 / 4
               for w in (wall_layout(g, "inner"), wall_layout(g, "outer")))


def global_volume_fraction(g, disks: float) -> float:
    """The paper's v-bar: the free disks (their area ``disks``, m^2) plus half of every wall
    disk, over pi (R_o^2 - R_i^2) at the final outer radius."""
    return (disks + wall_area_share(g)) / (math.pi * (g.outer_radius**2 - g.inner_radius**2))


WALL_WORK = 10
"""Wall disks per free disk above which a scene is told that its rings dominate the run time."""


def wall_work_note(scene) -> str | None:
    """Why the rings' wall disks will dominate a scene's run time, or None."""
    g = scene.geometry
    if g is None:
        return None
    walls = sum(wall_layout(g, ring).count for ring in ("inner", "outer"))
    if walls <= WALL_WORK * scene.n_free:
        return None
    return (f"the rings carry {walls} wall disks for {scene.n_free} free disks: every rank "
            "moves each wall disk at every step, at about the cost of a free disk, so the "
            f"steps cost about as much as a cell of {walls + scene.n_free} free disks (pardem "
            "check estimates the run time); fewer, larger wall disks (inner_wall_count, "
            "*_wall_diameter) make a rough ring at a fraction of the cost")


def check_sizes(g):
    """Why the wall-disk keys cannot make a cell, as ``(key, value, reason)``, or None: checked
    on the keys themselves before any layout or area is computed from them (a diameter of
    1e300 m overflows the area, a spacing of 1e-300 m the count)."""
    gap = g.outer_radius - g.inner_radius
    for ring in ("inner", "outer"):
        own = getattr(g, f"{ring}_wall_diameter")
        diameter = own or g.wall_particle_diameter
        if not diameter < gap:
            return (f"{ring}_wall_diameter" if own else "wall_particle_diameter", diameter,
                    f"the {ring} ring's wall disks must be smaller than the annulus gap "
                    f"outer_radius - inner_radius = {gap:.6g} m")
        if getattr(g, f"{ring}_wall_count") is None:
            around = 2.0 * math.pi * (g.inner_radius if ring == "inner" else g.outer_radius)
            count = around / g.wall_particle_spacing
            if count > MAX_WALL_DISKS:
                return ("wall_particle_spacing", g.wall_particle_spacing,
                        f"gives {count:.3g} wall disks on the {ring} ring ({around:.6g} m "
                        f"around), more than {MAX_WALL_DISKS}")
    return None


def check_layout(g, ring: str, smallest_free: float):
    """Why ring's layout cannot hold the free disks (smallest diameter ``smallest_free``, m),
    as ``(key, value, reason)``, or None if it can. Without the flat surface the disks alone
    must keep every free disk in the cell: the gap between neighbours, at the largest radius
    they reach (the outer ring starts extended), must be narrower than the smallest free disk."""
    w = wall_layout(g, ring)
    if w.count > MAX_WALL_DISKS:
        return (f"{ring}_wall_count", w.count, f"more than {MAX_WALL_DISKS} disks on a ring "
                f"(diameter {w.diameter!r} m; every rank holds and moves them)")
    if w.count > MAX_DISKS_PER_DIAMETER * 2.0 * math.pi * w.radius / w.diameter:
        return (f"{ring}_wall_count", w.count, f"more than {MAX_DISKS_PER_DIAMETER} disks per "
                f"wall-disk diameter along the ring (circumference {2 * math.pi * w.radius:.6g} m"
                f", diameter {w.diameter!r} m)")
    if w.flat:
        return None
    if w.count == 0:
        return (f"{ring}_flat_surface", False, f"a ring with {ring}_wall_count = 0 (smooth) needs "
                "its flat surface, or the free disks would leave the cell through it")
    widest = g.outer_start_radius if ring == "outer" else g.inner_radius
    if w.count == 1:
        return (f"{ring}_flat_surface", False, f"without the flat surface a single wall disk "
                f"leaves the rest of the {ring} ring open for the free disks to leave the cell; "
                "use more wall disks or keep the flat surface")
    gap = 2.0 * widest * math.sin(math.pi / w.count) - w.diameter
    if gap >= smallest_free:
        return (f"{ring}_flat_surface", False, f"without the flat surface the {w.count} wall "
                f"disks leave gaps of {gap:.6g} m (at radius {widest:.6g} m), wide enough for the "
                f"smallest free disk ({smallest_free:.6g} m) to pass; use more wall disks or keep "
                "the flat surface")
    return None


def wall_disk_angles(count: int) -> np.ndarray:
    """Angles (rad) of ``count`` disks evenly spaced along a ring, the first at angle 0."""
    return 2.0 * math.pi * np.arange(count) / count if count else np.zeros(0)


def ring_disks(scene) -> Glued:
    """The disks glued to the two rings at t = 0: the inner ring's on its radius, the outer
    ring's on its starting radius (each ring's ``wall_layout``)."""
    g = scene.geometry
    if g is None:
        return NO_DISKS
    inner, outer = wall_layout(g, "inner"), wall_layout(g, "outer")
    phi_in = wall_disk_angles(inner.count)
    phi_out = wall_disk_angles(outer.count)
    r0 = np.concatenate([np.full(phi_in.size, g.inner_radius),
                         np.full(phi_out.size, g.outer_start_radius)])
    phi = np.concatenate([phi_in, phi_out])
    return Glued(np.column_stack([r0 * np.cos(phi), r0 * np.sin(phi)]),
                 np.concatenate([np.full(phi_in.size, inner.diameter / 2),
                                 np.full(phi_out.size, outer.diameter / 2)]),
                 np.concatenate([np.full(phi_in.size, INNER_WALL),
                                 np.full(phi_out.size, OUTER_WALL)]).astype(np.int8), phi)


RINGS = Boundary(
    "rings", ("[geometry]",), (INNER_WALL, OUTER_WALL),
    ring_disks, moves=True, surface=True, present=lambda scene: scene.geometry is not None,
    summary="the Couette cell's two rings: flat surfaces and glued disks, the inner ring "
            "turning, the outer one compressing")

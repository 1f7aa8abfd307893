"""Initial configurations: random non-overlapping placement in the extended annulus (Couette) or
the explicit particles of a free scene, plus the wall disks of the boundaries.

Stage: set-up. Returns plain arrays ordered by gid (free particles first, then the wall disks
of every boundary, boundaries/registry.py). Randomness comes from one generator seeded by the
scene seed, so every rank builds the same configuration.

Placement: near 0.5 area fraction, random sequential insertion jams, so particles sit on a
triangular lattice whose spacing is as large as the annulus allows, each jittered within the room
its lattice cell leaves, and the lattice sites used are a random subset. The lattice is spaced
by the largest disk: where a size distribution's largest disk makes it too coarse for the
count, the disks are inserted at random by their own sizes instead (``insertion.py``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .scene import Scene, SceneError
from .species import species_disks
from ..boundaries.registry import glued_disks
from ..contact.pairs import species_count
from ..core.state import FREE, OUTER_WALL, ROW_ROOM, Particles, new_particles
from ..boundaries.walls import wall_layout


class Initial(NamedTuple):
    """Arrays by gid: x [n,2] (m), v [n,2] (m/s), omega [n] (rad/s), radius [n] (m), mass [n]
    (kg, inf for wall disks), kind [n], phi0 [n] (rad), species [n] (partner numbers,
    contact/pairs.py: wall disks from a file take S, the [contact] law with every partner);
    n_free; how the free disks were placed (``PLACEMENTS``)."""

    x: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    radius: np.ndarray
    mass: np.ndarray
    kind: np.ndarray
    phi0: np.ndarray
    species: np.ndarray
    n_free: int
    placement: str = "given"


PLACEMENTS = {"given": "given in the scene",
              "lattice": "on a jittered triangular lattice spaced by the largest disk",
              "inserted": "inserted at random by their own sizes (a lattice spaced by the "
                          "largest disk holds too few)"}
"""How ``initial_configuration`` placed the free disks, in words."""


def initial_configuration(scene: Scene) -> Initial:
    """The free disks (placed, or a free scene's own), then every boundary's wall disks
    (``boundaries.glued_disks``), at rest and infinitely massive."""
    if scene.info.kind == "free":
        p = scene.particles
        x, v, omega = np.column_stack([p.x, p.y]), np.column_stack([p.vx, p.vy]), p.omega
        radius, mass = 0.5 * np.asarray(p.diameter, float), p.mass
        labels, how = p.species, "given"
    else:
        x, radius, mass, labels, how = _couette(scene)
        v, omega = np.zeros_like(x), np.zeros(radius.size)
    n, w = radius.size, glued_disks(scene)
    k, s = w.radius.size, species_count(scene)
    return Initial(np.vstack([x, w.x]), np.vstack([v, np.zeros((k, 2))]),
                   np.concatenate([omega, np.zeros(k)]), np.concatenate([radius, w.radius]),
                   np.concatenate([mass, np.full(k, np.inf)]),
                   np.concatenate([np.full(n, FREE, np.int8), w.kind]),
                   np.concatenate([np.zeros(n), w.phi0]),
                   np.concatenate([labels, np.where(w.kind == OUTER_WALL, s + 1, s)]).astype(
                       np.int8), n, how)


def _couette(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
    """Free disks placed at random between the rings (clear of their wall disks): x, radius,
    mass, species, how (``PLACEMENTS``)."""
    g = scene.geometry
    rng = np.random.default_rng(scene.info.seed)
    counts = [s.count for s in scene.species]
    n = sum(counts)
    labels = rng.permutation(np.repeat(np.arange(len(counts)), counts))
    radius, mass = np.empty(n), np.empty(n)
    for k, (d, m) in enumerate(species_disks(scene)):  # a species' disks in its drawn order
        radius[labels == k] = d / 2
        mass[labels == k] = m
    rmax = radius.max()
    inner, outer = wall_layout(g, "inner"), wall_layout(g, "outer")
    # clear of the wall disks (or the flat ring) of each ring
    r_in_clear = g.inner_radius + (inner.diameter / 2 if inner.count else 0.0)
    r_out_clear = g.outer_start_radius - (outer.diameter / 2 if outer.count else 0.0)
    r_lo = r_in_clear + rmax * 1.01
    r_hi = r_out_clear - rmax * 1.01
    sites, spacing = _lattice_sites(r_lo, r_hi, n, 2.0 * rmax * 1.001)
    if sites is None:  # a lattice spaced by the largest disk is too coarse: each by its size
        x = _inserted(scene, radius, r_in_clear, r_out_clear, rng, lattice_fit=spacing or 0)
        return x, radius, mass, labels, "inserted"
    chosen = sites[np.sort(rng.choice(len(sites), size=n, replace=False))]
    # jitter within the site's cell, and never across the band the centre must stay in (clear
    # of both rings' wall disks): in a sparse scene the cell is much wider than the band
    r_site = np.hypot(chosen[:, 0], chosen[:, 1])
    band = np.minimum(r_site - (r_in_clear + radius), (r_out_clear - radius) - r_site)
    room = np.maximum(np.minimum(0.5 * spacing - radius, band), 0.0) * 0.99
    ang = rng.uniform(0.0, 2.0 * math.pi, n)
    rad = room * np.sqrt(rng.uniform(0.0, 1.0, n))
    x = chosen + np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
    return x, radius, mass, labels, "lattice"


INSERTION_TRIALS = 100_000
"""Random trial points per disk before the insertion gives up (a dilute start needs a few)."""


def _inserted(scene: Scene, radius: np.ndarray, r_in_clear: float, r_out_clear: float,
              rng: np.random.Generator, lattice_fit: int) -> np.ndarray:
    """Centres of disks of ``radius`` inserted at random by their own sizes, largest first
    (``insertion.py``), clear of both rings' wall disks; SceneError if they do not fit."""
    from .insertion import insert_disks  # compiled: loaded only for the starts that need it

    g = scene.geometry
    order = np.argsort(-radius, kind="stable")
    r = radius[order]
    lo, hi = r_in_clear + r * 1.01, r_out_clear - r * 1.01
    seed = int(rng.integers(2**31 - 1))
    x_sorted, placed = insert_disks(r, lo, hi, seed, INSERTION_TRIALS)
    n = radius.size
    if placed < n:
        area = math.pi * (g.outer_start_radius**2 - g.inner_radius**2)
        nu = float(np.sum(math.pi * radius**2)) / area
        raise SceneError(
            f"cannot place {n} particles between the inner ring ({g.inner_radius} m) and "
            f"[geometry] outer_start_radius = {g.outer_start_radius} m: a triangular lattice "
            f"spaced by the largest disk holds {lattice_fit}, and random insertion by each "
            f"disk's own size stalled after {placed} (the disks would fill {nu:.3f} of the "
            "area; random insertion stops near 0.55); increase outer_start_radius or reduce "
            "the counts")
    x = np.empty_like(x_sorted)
    x[order] = x_sorted
    return x


def _lattice_sites(r_lo: float, r_hi: float, n: int, min_spacing: float):
    """Triangular-lattice sites in the annulus r_lo <= r <= r_hi: the largest spacing (>=
    min_spacing) that still gives n sites. Returns (sites, spacing) or (None, max_sites)."""
    if r_hi <= r_lo:
        return None, 0
    area = math.pi * (r_hi**2 - r_lo**2)
    spacing = max(math.sqrt(area / (n * math.sqrt(3) / 2)), min_spacing)
    while True:
        sites = _triangular(r_lo, r_hi, spacing)
        if len(sites) >= n:
            return sites, spacing
        if spacing <= min_spacing:
            return None, len(sites)
        spacing = max(spacing * 0.99, min_spacing)


def _triangular(r_lo: float, r_hi: float, s: float) -> np.ndarray:
    ny = int(2 * r_hi / (s * math.sqrt(3) / 2)) + 2
    nx = int(2 * r_hi / s) + 2
    jj, ii = np.mgrid[-ny // 2:ny // 2 + 1, -nx // 2:nx // 2 + 1]
    px = (ii + 0.5 * (jj % 2)) * s
    py = jj * s * math.sqrt(3) / 2
    r = np.hypot(px, py)
    keep = (r >= r_lo) & (r <= r_hi)
    return np.column_stack([px[keep], py[keep]])


def cell_rows(init: Initial, hist: int, idx: np.ndarray | None = None,
              capacity: int = 0) -> Particles:
    """The particle arrays of the rows ``idx`` (gids, in that order; None: the whole cell in
    gid order) in arrays of ``capacity`` rows (at least the rows), with ``hist`` history
    columns for the ring contacts (0: none). A rank builds only its own share and the wall
    disks: whole-cell arrays on every rank were most of a large scene's set-up memory."""
    if idx is None:
        idx = np.arange(init.radius.size)
    n = idx.size
    arrays = new_particles(max(n, capacity), hist)
    ps = Particles(*(a[:n] for a in arrays))
    ps.gid[:] = idx
    ps.kind[:] = init.kind[idx]
    ps.species[:] = init.species[idx]
    ps.x[:] = init.x[idx]
    ps.v[:] = init.v[idx]
    ps.omega[:] = init.omega[idx]
    ps.radius[:] = init.radius[idx]
    ps.mass[:] = init.mass[idx]
    ps.inv_mass[:] = 1.0 / ps.mass
    ps.inv_inertia[:] = 2.0 / (ps.mass * ps.radius**2)  # I = m d^2 / 8
    ps.phi0[:] = init.phi0[idx]
    ps.e0[:] = np.column_stack([np.cos(ps.phi0), np.sin(ps.phi0)])
    return arrays


def share_rows(n: int, x_free: np.ndarray, decomp) -> tuple[np.ndarray, int, int]:
    """This rank's rows of a cell of ``n`` particles: [its sector's free particles | every wall
    disk] as gids, ascending; how many are free; the arrays' capacity (under MPI with room,
    ``ROW_ROOM``, for the ghosts and arrivals of the first exchange). The annulus is cut first
    (``decomp.place_cut``, from every free particle's position ``x_free``)."""
    decomp.place_cut(x_free)
    mine = np.flatnonzero(decomp.cut.owner(x_free) == decomp.rank)
    idx = np.concatenate([mine, np.arange(x_free.shape[0], n)])
    return idx, mine.size, int(ROW_ROOM * idx.size) if decomp.parallel else idx.size


def rank_share(init: Initial, decomp, hist: int):
    """This rank's particle arrays of a fresh start (``share_rows``), built for these rows
    alone, how many rows are free and how many there are."""
    idx, n_mine, capacity = share_rows(init.radius.size, init.x[:init.n_free], decomp)
    return cell_rows(init, hist, idx, capacity), n_mine, idx.size

"""Struct-of-arrays state: the particle arrays, the pair list with its contact history and the
forces it applied, the scalar parameters of a scene, and the clock.

Stage: data. Every compiled kernel reads and writes these arrays in place; nothing here allocates
during a step. Units are SI throughout.

Layout invariants
- Particles are stored as [owned free particles | wall disks | ghosts]. Each particle
  has a global id ``gid``; free particles have gids 0..N_free-1 and wall disks the gids after them,
  so "sum a particle's contacts in gid order" also fixes where wall contacts fall in the sum.
- The pair list holds candidate pairs (Verlet list) in canonical order: sorted by
  (lower gid, higher gid), with ``i`` the lower-gid partner. Only touching pairs contribute.
- ``hist`` (the contact history, m) is stored per pair, aligned with the pair list, with the
  columns of the scene's contact model (contact.model.history_columns: spring, rolling
  spring, eta); a model without history stores zero rows.
- ``fn``, ``ft`` per pair (and ``wall_fn``, ``wall_ft`` per ring candidate) are the normal and
  tangential forces the last force evaluation applied: output and averaging read them, so they
  report what the step did (no second evaluation of the law).
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, NamedTuple

import numba as nb
import numpy as np
from numba import literal_unroll

from .jit import JIT
from .timing import END, FIRST

if TYPE_CHECKING:
    from ..contact.params import LawParams
    from ..boundaries.walls import Rings

FREE, INNER_WALL, OUTER_WALL, FIXED_WALL = 0, 1, 2, 3
"""Values of ``Particles.kind``: a free disk, or a wall disk and the boundary it is glued to
(the inner ring, the outer ring, none: a disk that never moves; boundaries/registry.py)."""


class Particles(NamedTuple):
    """Per-particle arrays, length n (capacity). Shapes in brackets, units in parentheses.

    gid [n] int64: global id. kind [n] int8: FREE / INNER_WALL / OUTER_WALL / FIXED_WALL.
    species [n] int8: the partner number of its contacts' pair laws (contact/pairs.py: a free
    disk's species, S or S + 1 for the inner or outer ring's wall disks, S for wall disks
    from a file).
    x [n,2] (m), v [n,2] (m/s), theta [n] (rad), omega [n] (rad/s, counter-clockwise positive).
    f [n,2] (N) and tau [n] (N m): the force and torque of the current positions.
    radius [n] (m), mass [n] (kg), inv_mass [n] (1/kg), inv_inertia [n] (1/(kg m^2)):
    inverse mass and inertia are 0 for prescribed bodies.
    phi0 [n] (rad): a wall disk's angular position on its ring at t = 0 (0 for free particles);
    e0 [n,2]: its unit vector (cos phi0, sin phi0), so moving the walls costs one cos/sin a step.
    v_pred [n,2] (m/s), w_pred [n] (rad/s): velocity and spin predicted at the new full step,
    v(t+dt) ~ v(t+dt/2) + dt/2 a(t); the velocity-dependent forces (damping, tangential
    spring) use them, which makes the contact velocity second-order accurate in dt.
    x_ref [n,2] (m): positions at the last neighbour-list build (skin bookkeeping).
    hist_wall [n,w] (m): history of the contact with a flat ring surface (the pair history's
    columns; a disk cannot touch both rings, so one row suffices); zero rows without history.
    """

    gid: np.ndarray
    kind: np.ndarray
    species: np.ndarray
    x: np.ndarray
    v: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    f: np.ndarray
    tau: np.ndarray
    radius: np.ndarray
    mass: np.ndarray
    inv_mass: np.ndarray
    inv_inertia: np.ndarray
    phi0: np.ndarray
    e0: np.ndarray
    v_pred: np.ndarray
    w_pred: np.ndarray
    x_ref: np.ndarray
    hist_wall: np.ndarray


class Pairs(NamedTuple):
    """Verlet pair list with capacity; ``count[0]`` pairs are valid.

    i, j [cap] int32: local indices, gid[i] < gid[j]. hist [cap,w] (m): contact history
    (zero rows without one). fn [cap] (N), ft [cap,2] (N): normal force along n and tangential
    force on i applied at the last force evaluation (0 for pairs that do not touch).
    wall [capw] int32, wall_count[0]: free particles near a flat ring surface (candidates for
    flat-wall contacts); wall_fn [capw], wall_ft [capw,2]: their applied forces (N).
    """

    i: np.ndarray
    j: np.ndarray
    hist: np.ndarray
    count: np.ndarray
    wall: np.ndarray
    wall_count: np.ndarray
    fn: np.ndarray
    ft: np.ndarray
    wall_fn: np.ndarray
    wall_ft: np.ndarray


class Params(NamedTuple):
    """Parameters of a run: ``law`` (contact.model.LawParams: the material), ``rings``
    (walls.Rings: the geometry and motion of the rings), ``pair_law`` (the laws per pair of
    partners, contact.pairs.pair_table; empty without pair tables), and the run's own: dt
    (s), skin (m, Verlet skin), mu_b_g = mu_bottom g (m/s^2, bottom friction),
    escape_radius (m: a particle farther than this from the axis is an error; free scenes:
    inf; Couette scenes check against the rings' current radii instead), wall_skin (m: the extra skin of a free disk's
    pairs with wall disks, whose prescribed motion then does not force a build every skin/2;
    set at each build, ``neighbors.next_wall_skin``), inner_disks (the inner ring carries
    wall disks), wall_disks (either ring does: wall disks that move, whose travel the lists
    must cover)."""

    law: LawParams
    rings: Rings
    pair_law: np.ndarray
    dt: float
    skin: float
    mu_b_g: float
    escape_radius: float
    wall_skin: float = 0.0
    inner_disks: bool = False
    wall_disks: bool = False


class Clock(NamedTuple):
    """Integer clock. step[0]: steps taken (time = step * dt, never accumulated, so that restarts
    and ranks agree bit for bit). phase[0]: 0 = step complete, 1 = drifted but forces pending,
    2 = forces only (step.FORCES_ONLY).
    n_owned[0]: particles integrated (the leading block: free particles this rank owns).
    n_local[0]: owned particles + wall disks. n_moving[0] <= n_local[0]: owned particles + the
    wall disks near this rank's sector, stored first: the bodies the step loop moves (the
    other wall disks are placed at exchanges and before output; one rank: all).
    n_ghost[0]: ghost copies of other ranks' particles, stored after them (0 on one rank).
    r_out_ref[0] (float array, m): outer-ring radius at the last neighbour build;
    step_ref[0]: the step of the last neighbour build.
    reach[0] (m): bound on how much any overlap can change in half a step, 2 max|v| dt/2
    (pairs that close to touching get their share of the damping force).
    disp[0] (m): the largest displacement of a free particle since the previous neighbour
    build plus the outer ring's move, over all ranks, at the step that asked for the latest
    build (diagnostics; exchanges are decided from positions, Decomposition.exchange_due).
    deep (float array [4]): the first overlap beyond contact.overlap.MAX_OVERLAP on this rank,
    (t s, gid of i, gid of j or -1/-2 for the inner/outer ring surface, overlap over the
    smaller diameter); t < 0: none. The step loop stops every rank at the next step. Then
    deep[timing.FIRST:timing.END] (s, count): the stage timers of a step loop compiled with
    ``Timing(on=True)`` (``core/timing.py``; in this array so that the Clock's numba type, and
    with it the untimed loop's machine code, is the one it was before the timers).
    """

    step: np.ndarray
    phase: np.ndarray
    n_owned: np.ndarray
    n_local: np.ndarray
    n_moving: np.ndarray
    n_ghost: np.ndarray
    r_out_ref: np.ndarray
    reach: np.ndarray
    disp: np.ndarray
    step_ref: np.ndarray
    deep: np.ndarray


ROW_ROOM = 1.25
"""Under MPI a rank's particle arrays hold this many times its rows, so that an exchange
(arrivals, ghosts) usually writes into them in place instead of into new, larger arrays."""


def new_particles(n: int, hist: int) -> Particles:
    """Zeroed particle arrays for n particles with ``hist`` history columns (0: none)."""
    z = np.zeros
    return Particles(
        gid=z(n, np.int64), kind=z(n, np.int8), species=z(n, np.int8), x=z((n, 2)),
        v=z((n, 2)), theta=z(n),
        omega=z(n), f=z((n, 2)), tau=z(n), radius=z(n), mass=z(n), inv_mass=z(n),
        inv_inertia=z(n), phi0=z(n), e0=z((n, 2)), v_pred=z((n, 2)), w_pred=z(n),
        x_ref=z((n, 2)), hist_wall=z((n if hist else 0, max(hist, 2))),
    )


def new_pairs(capacity: int, wall_capacity: int, hist: int) -> Pairs:
    """Empty pair list with the given capacities and ``hist`` history columns."""
    return Pairs(
        i=np.zeros(capacity, np.int32), j=np.zeros(capacity, np.int32),
        hist=np.zeros((capacity if hist else 0, max(hist, 2))), count=np.zeros(1, np.int64),
        wall=np.zeros(wall_capacity, np.int32), wall_count=np.zeros(1, np.int64),
        fn=np.zeros(capacity), ft=np.zeros((capacity, 2)), wall_fn=np.zeros(wall_capacity),
        wall_ft=np.zeros((wall_capacity, 2)),
    )


def new_clock(n_owned: int, n_local: int, r_out0: float) -> Clock:
    return Clock(
        step=np.zeros(1, np.int64), phase=np.zeros(1, np.int64),
        n_owned=np.array([n_owned], np.int64), n_local=np.array([n_local], np.int64),
        n_moving=np.array([n_local], np.int64),
        n_ghost=np.zeros(1, np.int64),
        r_out_ref=np.array([r_out0]), reach=np.zeros(1), disp=np.zeros(1),
        step_ref=np.zeros(1, np.int64), deep=np.concatenate(([-1.0, 0.0, 0.0, 0.0], np.zeros(END - FIRST))),
    )


def particle_fields(hist: int) -> tuple[str, ...]:
    """Names of the per-particle arrays (``hist_wall`` only with a contact history)."""
    return tuple(k for k in Particles._fields if hist or k != "hist_wall")


def join_rows(parts: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


@functools.lru_cache(maxsize=None)
def row_columns(hist: int) -> dict[str, slice]:
    """Columns of each per-particle array in a packed row (``pack_particles``), in field
    order; the widths come from the arrays' own row shapes."""
    one = new_particles(1, hist)
    cols, c = {}, 0
    for k in particle_fields(hist):
        w = getattr(one, k)[0].size
        cols[k] = slice(c, c + w)
        c += w
    return cols


def row_width(hist: int) -> int:
    """Columns of a packed row."""
    return next(reversed(row_columns(hist).values())).stop


def packed(ps: Particles, idx: np.ndarray, hist: int) -> np.ndarray:
    """Rows ``idx`` of every per-particle array as one float64 matrix [len(idx), columns], in
    field order (``row_columns``): one compiled call instead of a numpy call per array, which
    at a neighbour build, with the interpreter's caches cold, cost several us each."""
    out = np.empty((len(idx), row_width(hist)))
    pack_particles(ps, np.asarray(idx, np.int64), out)
    return out


@nb.njit(**JIT)
def pack_particles(ps, idx, out):
    """out[r] = row idx[r] of every array of ps (integer ids and kinds are exact in float64
    below 2**53). Arrays with no rows (hist_wall without a history) are skipped."""
    c = 0
    for a in literal_unroll(ps):
        if a.shape[0] > 0:
            a2 = a.reshape((a.shape[0], -1))
            for q in range(a2.shape[1]):
                for r in range(idx.size):
                    out[r, c + q] = a2[idx[r], q]
            c += a2.shape[1]


@nb.njit(**JIT)
def unpack_particles(rows, ps, at):
    """The inverse of ``pack_particles``: rows [m, columns] into ps[at:at + m]."""
    c = 0
    for a in literal_unroll(ps):
        if a.shape[0] > 0:
            a2 = a.reshape((a.shape[0], -1))
            for q in range(a2.shape[1]):
                for r in range(rows.shape[0]):
                    a2[at + r, q] = rows[r, c + q]
            c += a2.shape[1]



@nb.njit(**JIT)
def move_rows(ps, src, dst, rows, take, put):
    """In place: row src[k] of every array of ps to row dst[k], then packed row rows[take[r]]
    (``pack_particles``' columns) to row put[r]. src and dst ascending, put disjoint from dst.
    At an exchange this replaces packing every owned row and unpacking it again (~3 passes of
    strided copies, ~60 ms at 147,000 rows) by one pass per array over the rows that move."""
    c = 0
    for a in literal_unroll(ps):
        if a.shape[0] > 0:
            a2 = a.reshape((a.shape[0], -1))
            _move_columns(a2, src, dst, rows[:, c:c + a2.shape[1]], take, put)
            c += a2.shape[1]


@nb.njit(**JIT)
def _move_columns(a, src, dst, rows, take, put):
    """``move_rows`` for one array. A row that moves down overwrites no row still to be read if
    the rows move in ascending order, a row that moves up if they move in descending order;
    the two sets do not interfere because src and dst both ascend."""
    for k in range(src.size):
        if dst[k] < src[k]:
            for q in range(a.shape[1]):
                a[dst[k], q] = a[src[k], q]
    for k in range(src.size - 1, -1, -1):
        if dst[k] > src[k]:
            for q in range(a.shape[1]):
                a[dst[k], q] = a[src[k], q]
    for r in range(put.size):
        for q in range(a.shape[1]):
            a[put[r], q] = rows[take[r], q]

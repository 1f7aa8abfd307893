"""The time-step loop: velocity Verlet with contact forces, compiled once per set of effects.

Stage: integration. ``make_stepper(options)`` returns a ``Stepper`` of jitted functions that run
many steps per Python call. One step (LAMMPS ``Verlet::iterate`` order):

    half kick   v += dt/2 f/m, w += dt/2 tau/I
    drift       x += dt v, theta += dt w;  rings and wall disks moved to t + dt;
                predict v(t+dt) = v + dt/2 f(t)/m for the velocity-dependent forces
                (both in one pass, integrate.kick_drift, with the previous step's closing
                 kick when the loop went on from it)
    ghosts      under MPI: neighbours' boundary particles refreshed (x, v_pred, w_pred), and
                every rank learns the global largest displacement and speed
                                                                    (parallel.refresh_ghosts)
    (stop here and return NEED_REBUILD if a pair not in the list could now be within reach
     of touching: largest free displacement since the last neighbour build + half the
     distance the fastest body covers in a step > skin/2, or, for a free disk and a wall disk,
     that displacement + the walls' travel + that distance > skin + wall_skin; the caller
     rebuilds the list and calls ``advance`` again, which resumes)
    forces      pair contacts in canonical pair order, then flat ring contacts (forces.py)
    half kick   (then bottom friction); deferred to the next step's pass over the particles
                unless this step ends the call (integrate.kick)

Time is ``step * dt`` (never accumulated). Reads/writes: Particles, Pairs, Clock; reads Params,
the ghost-refresh plan (None on one rank: no MPI code is compiled in).

``StepOptions`` (hashable, ``@static``: its values are part of its numba type) is closed over
by ``advance`` and passed on to the force loop: its switches are compile-time constants in
both, so a disabled effect is compiled out, and numba's disk cache serves the kernels to later
processes (the closure holds only plain values; a closure over another jitted function would
get a new cache key in every process).
"""

from __future__ import annotations

import functools
import math
from typing import Callable, NamedTuple

import numba as nb
import numpy as np

from ..contact.model import ContactOptions
from .forces import contact_forces, new_work
from .integrate import PEAK_LANES, kick, kick_drift, wall_travel
from .jit import JIT
from .static import static
from .timing import CLOSING, DRIFT, FORCES, REFRESH, STEPS, Timing, lap, stamp
from ..parallel.refresh import refresh_ghosts

OK, NEED_REBUILD, BAD_PARTICLE, MPI_FAILED, TOO_DEEP = 0, 1, 2, 3, 4
FORCES_ONLY = 2  # Clock.phase: the next advance call only computes the forces


@static
class StepOptions:
    """Compile-time switches of one scene. ``walls``: Couette rings are present. ``predict``:
    velocity-dependent forces use v + dt/2 a (else the half-step v); the integrator ([time]
    integrator) sets it together with ``contact.window``. ``timing``: per-stage timers in
    ``Clock.deep`` (``timing.py``; off, none are compiled in)."""

    contact: ContactOptions = ContactOptions()
    rotation: bool = True
    bottom_friction: bool = True
    walls: bool = True
    predict: bool = True
    timing: Timing = Timing()


class Stepper(NamedTuple):
    """Compiled functions of one scene: ``advance(ps, pairs, clock, prm, halo, target_step) ->
    (status, particle_index)`` and ``compute_forces(ps, pairs, clock, prm, halo, v2_max)``."""

    advance: Callable
    compute_forces: Callable


@functools.lru_cache(maxsize=None)
def make_stepper(opts: StepOptions) -> Stepper:
    """Compile (or load from numba's cache) the step loop for one set of effects."""
    if opts.contact.eta and not opts.contact.friction:
        raise ValueError("StepOptions: eta is tracked only with tangential friction")
    o = opts.contact
    tm = opts.timing
    # a closed-over constant: numba prunes the timers' branches before typing when it is off,
    # so the untimed loop is compiled from the same code as before the timers existed
    timed = tm.on

    @nb.njit(**JIT)
    def advance(ps, pairs, clock, prm, halo, target):
        h = 0.5 * prm.dt
        n_owned = clock.n_owned[0]
        n_all = clock.n_local[0] + clock.n_ghost[0]
        peaks = np.empty((2, PEAK_LANES))
        pending = False  # the last step's closing kick, left to the next kick_drift
        work = new_work(o, pairs.count[0])
        forces_only = clock.phase[0] == FORCES_ONLY
        if forces_only:  # synchronous velocities
            for k in range(n_all):
                ps.v_pred[k, 0] = ps.v[k, 0]
                ps.v_pred[k, 1] = ps.v[k, 1]
                ps.w_pred[k] = ps.omega[k]
        while forces_only or clock.step[0] < target or clock.phase[0] == 1:
            if timed:
                t = stamp(tm)
            if clock.phase[0] == 0:
                bad, disp, v2 = kick_drift(ps, clock, prm, opts, peaks, pending)
                pending = False
                if timed:
                    t = lap(tm, clock.deep, DRIFT, t)
                # ghosts to t + dt; every rank learns the global maxima (one rank: no-op), and
                # whether any rank has a bad particle or an overlap beyond MAX_OVERLAP since
                # the last step: every rank stops at this step
                deep = clock.deep[0] >= 0.0
                err, bad_any, disp, v2 = refresh_ghosts(ps, halo, clock.n_local[0],
                                                        bad >= 0 or deep, disp, v2,
                                                        clock.step[0], tm)
                if timed:
                    t = lap(tm, clock.deep, REFRESH, t)
                if err != 0:
                    return MPI_FAILED, -1
                if bad_any:
                    return (TOO_DEEP, -1) if deep else (BAD_PARTICLE, bad)
                clock.reach[0] = math.sqrt(v2) * prm.dt  # 2 max|v| dt/2
                # the list must hold every pair within reach of touching: free pairs
                # 2 max_disp + reach <= skin; a free disk and a wall disk (listed wall_skin
                # farther) max_disp + wall travel + reach <= skin + wall_skin
                if disp + 0.5 * clock.reach[0] > 0.5 * prm.skin or (
                        prm.wall_disks and disp + wall_travel(clock, prm)
                        + clock.reach[0] > prm.skin + prm.wall_skin):
                    clock.disp[0] = disp
                    return NEED_REBUILD, -1
            # the applied forces are stored for the state this call ends in (output reads them)
            record = forces_only or clock.step[0] >= target
            contact_forces(ps, pairs, n_all, prm, clock.step[0] * prm.dt, clock.reach[0], o,
                           opts.rotation, opts.walls, work, record)
            if timed:
                t = lap(tm, clock.deep, FORCES, t)
            if work.deep[0] >= 0.0 and clock.deep[0] < 0.0:  # the first: named by gid
                k = int(work.deep[0])
                ring = work.deep[2]
                clock.deep[0] = clock.step[0] * prm.dt
                clock.deep[1] = ps.gid[pairs.i[k]] if ring == 0.0 else ps.gid[k]
                clock.deep[2] = ps.gid[pairs.j[k]] if ring == 0.0 else -ring
                clock.deep[3] = work.deep[1]
            if forces_only:
                clock.phase[0] = 0
                return OK, -1
            if clock.step[0] < target:  # the loop goes on: the kick joins the next pass
                pending = True
            else:
                kick(ps, n_owned, h, prm, opts, True)
            if timed:
                lap(tm, clock.deep, CLOSING, t)
                clock.deep[STEPS] += 1.0
            clock.phase[0] = 0
        return OK, -1

    def compute_forces(ps, pairs, clock, prm, halo, v2):
        """Forces of the current state with synchronous velocities (start of a run); v2 is the
        largest squared speed over all ranks (m^2/s^2). Ghost velocities must be current."""
        clock.reach[0] = math.sqrt(v2) * prm.dt
        clock.phase[0] = FORCES_ONLY
        advance(ps, pairs, clock, prm, halo, clock.step[0])

    return Stepper(advance=advance, compute_forces=compute_forces)

"""``Simulation``: the state of one scene and its run loop.

Stage: driver. The physics of a step is compiled (``step.py``: kick, drift, ghost refresh,
forces, kick); this module builds the state, decides how many steps each compiled call runs,
rebuilds the neighbour lists when the step loop asks for it, and fires the writers
(``output/writers.py``) between calls. ``Simulation.run``:

    forces at t = 0 (or the checkpoint's state, forces and history)
    while step < end:
        advance(..., up to the next writer's step)   # many steps in compiled code
            NEED_REBUILD -> rebuild the lists (under MPI: migrate and select ghosts first
                            when the bodies have moved half the ghost margin), continue
            BAD_PARTICLE -> stop on every rank with the particle's id, time and position
            TOO_DEEP     -> stop on every rank naming the two particles (or the particle
                            and the ring), the time and the overlap beyond MAX_OVERLAP
        fire the due writers: ring sample, snapshot, checkpoint; progress line
    close the writers (final snapshot, checkpoint, ring averages)
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
import numpy as np

from .compile_ahead import compile_ahead, compile_first
from .contact.history import live_history, tracks_eta
from .contact.model import history_columns, law_params, options_for
from .output.progress import breakdown, end_progress, log_line, start_notes
from .output.progress import report as report_progress
from .output.restart import put_recorded_forces, restore
from .output.folder import FolderLock, claim, lock_unchanged
from .output.averages import make_averager, resume
from .output.writers import Checkpoints, Every, Snapshots
from .parallel import GHOST_MARGIN_SKINS, decomposition
from .core.memory import prepare_memory, reuse_freed_arrays
from .input.placement import initial_configuration, rank_share
from .core.neighbors import WALL_SKINS
from .core.rebuild import place_idle_walls, rebuild, rebuild_on_request
from . import stop
from .input.scene import Scene, SceneError
from .input.scene_file import write_scene
from .core.state import Params, new_clock, new_pairs
from .core.step import BAD_PARTICLE, MPI_FAILED, NEED_REBUILD, TOO_DEEP, StepOptions, make_stepper
from .core.timestep import check_step_count, resolve_step
from .core.watchdog import bad_particle_message, too_deep_message
from .views import StateViews
from .output.run_output import RunOutput
from .walls import rings_of, wall_layout


class SimulationError(RuntimeError):
    """The run became invalid (non-finite value, particle left the cell)."""


class Simulation(StateViews, RunOutput):
    """One scene's state and run loop: ``Simulation(scene, out_dir=None, restart=None,
    comm=None, overwrite=False, cut="auto")``, ``run(end=None, progress=True)``,
    ``advance_steps(n)``. ``out_dir`` must not hold another run unless ``overwrite``
    (output/folder.py). ``cut``: how the annulus is cut among the ranks ("auto": the cut with
    the fewest ghosts; "sectors"; "RxA": R rings of A sectors); results do not depend on it.

    Public state: ``time`` (s), ``step``, ``dt`` (s), ``n_free``, ``timers`` (s per stage),
    ``n_rebuilds``, ``rings`` (the in-situ RingAverager after a run with [averaging]).
    Gathered views (rank 0; None on the others): ``particle_arrays``, ``contacts``,
    ``ring_contacts``, ``checkpoint_state``. This rank's views: ``local_view``,
    ``local_tables``. With ``comm`` (an mpi4py communicator) every method that advances,
    gathers or measures is collective. An exception on one rank leaves the others waiting:
    a caller must then abort the communicator (``pardem run`` does; so do the tests).
    """

    def __init__(self, scene: Scene, out_dir: str | Path | None = None,
                 restart: str | Path | None = None, comm=None, overwrite: bool = False,
                 cut: str = "auto"):
        self.scene = scene
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self._early: list[str] | None = []  # log lines before the folder is claimed (log)
        self.step_length = resolve_step(scene)  # exact (s): the clock is step x this
        self.dt = float(self.step_length)
        e, g = scene.effects, scene.geometry
        self.contact = options_for(e, scene.time.integrator, tracks_eta(scene, out_dir is not None),
                                   scene.contact.normal)
        self.history_columns = history_columns(self.contact)
        self.hist = len(self.history_columns)
        self.options = StepOptions(self.contact, e.rotation, e.bottom_friction,
                                   scene.info.kind == "couette",
                                   predict=scene.time.integrator == "verlet")
        self.stepper = make_stepper(self.options)
        self.timers = {"forces+integration": 0.0, "neighbour rebuild": 0.0, "averaging": 0.0,
                       "snapshots": 0.0, "checkpoints": 0.0, "progress": 0.0}
        self.n_rebuilds = 0
        skin = scene.neighbors.skin or 0.1 * scene.min_free_diameter
        c = scene.contact
        inner, outer = (g is not None and wall_layout(g, ring).count > 0
                        for ring in ("inner", "outer"))
        walled = float(inner or outer)
        self.prm = Params(law_params(c, self.dt), rings_of(g), self.dt, skin,
                          c.mu_bottom * c.gravity, math.inf, wall_skin=WALL_SKINS * skin * walled,
                          inner_disks=float(inner), wall_disks=walled)
        prepare_memory(scene, comm)
        init = initial_configuration(scene)
        self.n_free = init.n_free
        self._free_radii = init.radius[:init.n_free].copy()
        self.decomp = decomposition(comm, 2.0 * float(init.radius[:init.n_free].max()) + skin,
                                    g.inner_radius if g else 0.0,
                                    margin=GHOST_MARGIN_SKINS * skin, cut=cut)
        compile_first(self.decomp)  # parallel runs: the kernels the cut needs, shared
        self.clock = new_clock(init.n_free, init.radius.size, self.prm.rings.r_out0)
        # the in-situ averager ([averaging] table; None without), kept across run() calls
        self.rings = make_averager(scene, self._free_radii, self.decomp)
        history, recorded = None, None
        self._series = None  # the snapshot numbering (output/series.py), from the first run
        self._end_step = None  # the checkpoint's step if its snapshot is an end snapshot
        if restart is None:  # this rank's rows only, built or read
            self.ps, n_owned, n = rank_share(init, self.decomp, self.hist)
        else:
            got = restore(restart, init, scene, self.dt, self.history_columns, self.decomp,
                          self.log)
            self.ps, n_owned, n, self.clock.step[0], history, recorded, averages, end = got
            self._end_step = self.step if end else None
            resume(self.rings, scene, self.dt, self.step, averages, restart, self.log)
        self.folder_lock = FolderLock(self.out_dir) if self.out_dir is not None else None
        # run files present when the folder was claimed (checked at the first run only)
        self._claimed = (claim(self.out_dir, self.decomp, scene, restart, overwrite,
                               self.folder_lock, self.log) if self.out_dir is not None else None)
        early, self._early = self._early, None
        for line in early:
            self.log(line)
        wall_radius = float(init.radius[init.n_free:].max(initial=0.0))
        del init  # the whole cell's arrays: not kept
        self.clock.n_owned[0], self.clock.n_local[0] = n_owned, n
        self.clock.n_moving[0] = n  # every wall disk is at time t: none idle yet
        # no owned particle comes this close to an idle wall disk between exchanges (order_walls)
        self.wall_margin = self.decomp.ghost_width + self.prm.wall_skin + 2.0 * wall_radius
        self.pairs = new_pairs(4 * n + 64, max(n // 4, 64), self.hist)
        compile_ahead(self, history)  # parallel runs: the ranks share a cold compile
        self._rebuild(history=history, rebalance=False)
        if restart is None:
            self._compute_forces()
        else:
            put_recorded_forces(self, *recorded)
        reuse_freed_arrays()  # the set-up's peak is past; builds reuse their blocks (memory.py)

    # -- public state ----------------------------------------------------------------------
    @property
    def time(self) -> float:
        """The time (s) output carries: the exact step count x step, correctly rounded."""
        return float(int(self.clock.step[0]) * self.step_length)

    @property
    def clock_time(self) -> float:
        """The kernels' time (s), step x dt in floating point (``time`` to the last bit)."""
        return float(self.clock.step[0] * self.dt)

    @property
    def step(self) -> int:
        return int(self.clock.step[0])

    def log(self, text: str) -> None:
        """Append a time-stamped line to DIR/log.txt (rank 0); kept until the folder is
        claimed, which a log.txt already written would make look like another run's."""
        if self._early is not None:
            self._early.append(text)
        elif self.decomp.rank == 0:
            log_line(self.out_dir, text)

    def breakdown(self) -> str:
        return breakdown(self)

    def reset_timers(self) -> None:
        """Zero the stage timers, the waiting time and the build count (benchmarks)."""
        for key in self.timers:
            self.timers[key] = 0.0
        self.decomp.wait[0] = 0.0
        self.n_rebuilds = 0

    # -- setting up -------------------------------------------------------------------------
    def set_particles(self, ids, position=None, velocity=None, omega=None) -> None:
        """Prepared initial conditions (collective): give the free particles ``ids`` new
        positions [k,2] (m), velocities [k,2] (m/s) and/or spins [k] (rad/s), then rebuild the
        lists and recompute the forces (springs of pairs that still touch are kept)."""
        ids = np.atleast_1d(np.asarray(ids, np.int64))
        n_owned = int(self.clock.n_owned[0])
        rows = np.searchsorted(self.ps.gid[:n_owned], ids)
        rows = np.minimum(rows, max(n_owned - 1, 0))
        here = (self.ps.gid[rows] == ids) if n_owned else np.zeros(ids.size, bool)
        for array, values in ((self.ps.x, position), (self.ps.v, velocity),
                              (self.ps.omega, omega)):
            if values is not None:
                array[rows[here]] = np.asarray(values, float).reshape(
                    (ids.size,) + array.shape[1:])[here]
        self.refresh()

    def refresh(self) -> None:
        """Rebuild the neighbour lists and recompute the forces after the state was edited."""
        self._rebuild()
        self._compute_forces()

    def _compute_forces(self) -> None:
        n = int(self.clock.n_local[0])
        v2 = float((self.ps.v[:n] ** 2).sum(axis=1).max()) if n else 0.0
        self.stepper.compute_forces(self.ps, self.pairs, self.clock, self.prm, self.decomp.halo,
                                    self.decomp.max(v2))

    # -- neighbour lists ----------------------------------------------------------------------
    def _rebuild(self, history=None, rebalance: bool = True, exchange: bool = True) -> None:
        rebuild(self, history, rebalance, exchange)

    def history_table(self):
        """This rank's non-zero contact history: (gid_lo, gid_hi, rows), sorted by key."""
        return live_history(self.ps.gid, self.pairs.i, self.pairs.j, self.pairs.hist,
                            int(self.pairs.count[0]))

    # -- running ----------------------------------------------------------------------------
    def run(self, end: float | None = None, progress: bool = True) -> None:
        """Advance to time ``end`` (s; default the scene's [time] end), firing the writers:
        snapshots and checkpoints into ``out_dir`` (if set, under its folder lock: another job
        writing there is refused), ring samples ([averaging]), and a progress line on stderr
        (rank 0). Under MPI every rank calls this; chunk sizes and report times are rank 0's
        decisions."""
        if self.out_dir is None:
            return self._run(end, progress)
        if self._claimed is not None:  # the first run() since the claim
            self.decomp.bcast_call(lock_unchanged, self.out_dir, self.folder_lock, self._claimed)
            self._claimed = None
        else:
            self.decomp.bcast_call(self.folder_lock.acquire)
        try:
            self._run(end, progress)
        finally:
            self.folder_lock.release()

    def _run(self, end: float | None, progress: bool) -> None:
        if end is not None:  # the scene's own end was checked with its step
            check_step_count(self.scene, self.dt, end, "--end", self.time)
        end = self.scene.time.end if end is None else end
        end_step = int(round(end / self.dt))
        if end_step < self.step:
            raise SceneError(f"--end {end:.6g} s lies before the run's current time "
                             f"{self.time:.6g} s (the checkpoint's): nothing to run")
        out = self.scene.output
        root = self.decomp.rank == 0
        writers = self._ring_writers(end_step)
        for w in writers:  # a sample at the start step (t = 0 with start = 0) is one too
            if w.trigger.due(self.step):
                self._timed(w.stage, w.write, self)
        if self.out_dir is not None:
            snapshots = Snapshots(Every(self.snapshot_period))
            writers += [snapshots, Checkpoints(Every(round(out.checkpoint_interval / self.dt)))]
            if root:
                self.out_dir.mkdir(parents=True, exist_ok=True)
                write_scene(self.scene, self.out_dir / "scene.toml")
            self.log(f"run {self.scene.info.name}: t = {self.time:.6g} s to {end:.6g} s, "
                     f"{self.n_free} particles, dt = {self.dt:.6g} s, {self.decomp.describe()}")
            self._snapshot_series()  # the folder's series and indexes, checked before a step
            if snapshots.trigger.due(self.step):
                self._timed("snapshots", self.write_snapshot)
        if root:  # said, not silently rounded or cut short
            for note in start_notes(self.scene, self.step_length, end, self.rings is not None):
                self.log(f"note: {note}")
                sys.stderr.write(f"pardem: note: {note}\n")
        since = [time.perf_counter(), self.step]  # the last report's wall time and step
        signum = 0  # a signal received on any rank (pardem.stop)
        chunk, last_report = 1000, 0.0
        every = 1.0 if progress else (10.0 if self.out_dir is not None else math.inf)
        while self.step < end_step:
            step = self.step
            target = min(end_step, step + chunk, *(w.trigger.next_after(step) for w in writers))
            t0 = time.perf_counter()
            self._advance_to(int(target))
            t1 = time.perf_counter()
            done = self.step - step
            if t1 - t0 > 0 and done > 0:  # aim at ~0.25 s of compiled work per call
                chunk = int(min(max(done * 0.25 / (t1 - t0), 100), 1_000_000))
            report = t1 - last_report > every or (self.step >= end_step and every < math.inf)
            chunk, report = self.decomp.bcast((chunk, report))
            signum = int(self.decomp.max(float(stop.requested())))  # a signal to any rank
            for w in writers:
                if w.trigger.due(self.step):
                    self._timed(w.stage, w.write, self)
            if report or signum:
                last_report = t1
                self._timed("progress", report_progress, self, since, end_step, progress)
            if signum:
                break
        for w in writers:
            self._timed(w.stage, w.close, self)
        self.log(breakdown(self))
        if progress and root:
            end_progress()
            sys.stderr.write(breakdown(self) + "\n")
        if signum:  # stopped by a signal (on some rank); the writers have closed
            stopped = stop.Interrupted(signum, self.time, self.step)
            self.log(f"run {stopped}; the checkpoint holds this state")
            raise stopped

    def advance_steps(self, n: int) -> None:
        """Take n steps without output (tests, benchmarks); collective under MPI."""
        self._advance_to(self.step + n)

    def _advance_to(self, target: int) -> None:
        while True:
            t0 = time.perf_counter()
            status, bad = self.stepper.advance(self.ps, self.pairs, self.clock, self.prm,
                                               self.decomp.halo, target)
            t1 = time.perf_counter()
            self.timers["forces+integration"] += t1 - t0
            if status == NEED_REBUILD:  # every rank returns at the same step (global maxima)
                rebuild_on_request(self)
                self.timers["neighbour rebuild"] += time.perf_counter() - t1
            elif status in (BAD_PARTICLE, TOO_DEEP):
                self._stop(bad_particle_message(self, bad) if bad >= 0 else None)
            elif status == MPI_FAILED:
                raise RuntimeError(f"MPI ghost exchange failed on rank {self.decomp.rank} at "
                                   f"step {self.step}")
            else:
                # an overlap beyond MAX_OVERLAP in the forces of a call's last step: the loop
                # stops every rank at the next step's ghost refresh, which this call did not
                # reach (one collective per call)
                if self.decomp.max(float(self.clock.deep[0] >= 0.0)) > 0.0:
                    self._stop(None)
                place_idle_walls(self)
                return

    def _stop(self, message: str | None) -> None:
        """Stop every rank with the first rank's message (collective): an overlap beyond
        MAX_OVERLAP on this rank first (it is why particles go bad), else ``message``."""
        if self.clock.deep[0] >= 0.0:
            message = too_deep_message(self.clock.deep, self.dt)
        message = self.decomp.first_message(message)
        self.log(f"run stopped: {message}")
        raise SimulationError(message)

    def _timed(self, stage: str, fn, *args) -> None:
        t0 = time.perf_counter()
        fn(*args)
        self.timers[stage] += time.perf_counter() - t0

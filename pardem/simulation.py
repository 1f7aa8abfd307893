"""``Simulation``: the run loop of one scene's state (``builder.py`` builds the state).

Stage: driver. The physics of a step is compiled (``core/step.py``: kick, drift, ghost refresh,
forces, kick); this module decides how many steps each compiled call runs,
has its ``Rebuilder`` (``core/rebuild.py``) rebuild the neighbour lists when the step loop
asks for it, and fires the writers
(``output/writers.py``) between calls. ``Simulation.run``:

    forces at t = 0 (or the checkpoint's state, forces and history)
    while step < end:
        advance(..., up to the next writer's step)   # many steps in compiled code
            NEED_REBUILD -> rebuild the lists (under MPI: migrate and select ghosts first
                            when the bodies have moved half the ghost margin), continue
            BAD_PARTICLE -> stop on every rank with the particle's id, time and position
            TOO_DEEP     -> stop on every rank naming the two particles (or the particle
                            and the ring), the time and the overlap beyond MAX_OVERLAP
        largest overlap (collective): a warning past [warnings] overlap (output/warnings.py)
        fire the due writers: ring sample, snapshot, checkpoint; progress line
    close the writers (final snapshot, checkpoint, ring averages)
"""

from __future__ import annotations

import math
import sys
import time

from . import stop
from .builder import SimulationBuilder
from .core.memory import needed_bytes, peak_bytes, size_text
from .core.step import BAD_PARTICLE, MPI_FAILED, NEED_REBUILD, TOO_DEEP
from .core.timestep import check_step_count
from .core.watchdog import bad_particle_message, too_deep_message
from .input.scene import SceneError
from .input.scene_file import write_scene
from .output.folder import lock_unchanged
from .output.progress import breakdown, end_progress, stage_table, start_notes
from .output.progress import report as report_progress
from .output.run_output import RunOutput
from .output.warnings import RunWarnings
from .output.writers import Checkpoints, Every, Snapshots
from .views import StateViews


class SimulationError(RuntimeError):
    """The run became invalid (non-finite value, particle left the cell)."""


class Simulation(SimulationBuilder, StateViews, RunOutput):
    """One scene's state and its run loop.

    ``Simulation(scene, out_dir=None, restart=None, comm=None, overwrite=False, cut="auto",
    branch=None)`` builds the state of ``scene`` (a ``Scene``, from ``load_scene``): the
    particles placed at t = 0, or ``restart``, a checkpoint file or run folder of the same
    scene, continued exactly (``pardem run --restart``), or ``branch``, a prepared run's
    checkpoint continued with this scene's material and drive (``pardem run --from``; what
    carries over: docs/running.md). ``out_dir``: the run folder that ``run`` writes into
    (None: no files); it must not hold another run unless ``overwrite``. ``comm``: an mpi4py
    communicator to run on (None: serial, MPI never loaded). ``cut``: how the annulus is cut
    among the ranks ("auto": the cut with the fewest ghosts; "sectors"; "RxA": R rings of A
    sectors); results do not depend on it. ``timing``: compile per-stage timers into the
    step loop and print microseconds per step of each stage on every rank at the end of each
    ``run`` (``pardem run --timing``; off, the loop has no timers at all).

    Public state: ``time`` (s), ``step``, ``dt`` (s), ``n_free``, ``timers`` (s per stage),
    ``n_rebuilds``, ``rings`` (the in-situ RingAverager after a run with [averaging]).
    Gathered views (rank 0; None on the others): ``particle_arrays``, ``gathered``,
    ``contacts``, ``ring_contacts``, ``checkpoint_state``. This rank's views: ``local_view``,
    ``local_tables``. With ``comm`` every method that advances, gathers or measures is
    collective. An exception on one rank leaves the others waiting: a caller must then abort
    the communicator (``pardem run`` does; so do the tests).
    """

    _warnings: RunWarnings | None = None  # built by the first run()

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
        if self._warnings is None:
            self._warnings = RunWarnings(self)  # collective
        since = [time.perf_counter(), self.step]  # the last report's wall time and step
        signum = 0  # a signal received on any rank (pardem.stop)
        chunk, last_report = 1000, 0.0
        every = 1.0 if progress else (10.0 if self.out_dir is not None else math.inf)
        while self.step < end_step:
            step = self.step
            target = min(end_step, step + chunk, self._warnings.next_after(step),
                         *(w.trigger.next_after(step) for w in writers))
            t0 = time.perf_counter()
            self._advance_to(int(target))
            t1 = time.perf_counter()
            done = self.step - step
            if t1 - t0 > 0 and done > 0:  # aim at ~0.25 s of compiled work per call
                chunk = int(min(max(done * 0.25 / (t1 - t0), 100), 1_000_000))
            report = t1 - last_report > every or (self.step >= end_step and every < math.inf)
            chunk, report = self.decomp.bcast((chunk, report))
            signum = int(self.decomp.max(float(stop.requested())))  # a signal to any rank
            overlap = self._watch_overlap()  # collective
            for w in writers:
                if w.trigger.due(self.step):
                    self._timed(w.stage, w.write, self)
            if report or signum:
                last_report = t1
                self._timed("progress", report_progress, self, since, end_step, progress,
                            overlap)
            if signum:
                break
        for w in writers:
            self._timed(w.stage, w.close, self)
        self.log(breakdown(self))
        peak = self.decomp.max(peak_bytes())  # collective
        self.log(f"memory: peak {size_text(peak)} on the busiest rank (pardem check's estimate: "
                 f"{size_text(needed_bytes(self.scene))})")
        if progress and root:
            end_progress()
            sys.stderr.write(breakdown(self) + "\n")
        if self.options.timing.on:  # collective
            stages = stage_table(self)
            if root:
                self.log(stages)
                sys.stderr.write(stages + "\n")
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
                self.rebuilder.rebuild(forced=False)
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
                self.rebuilder.place_idle_walls()
                return

    def _stop(self, message: str | None) -> None:
        """Stop every rank with the first rank's message (collective): an overlap beyond
        MAX_OVERLAP on this rank first (it is why particles go bad), else ``message``."""
        if self.clock.deep[0] >= 0.0:
            message = too_deep_message(self.clock.deep[:4], self.dt)
        message = self.decomp.first_message(message)
        self.log(f"run stopped: {message}")
        raise SimulationError(message)

    def _watch_overlap(self) -> float:
        """The largest overlap (collective), and its warning. Measured after every compiled
        call, not only at the reports (a quiet run reports every 10 s, or never): a call is
        ~0.25 s of steps, the overlap's pass over the pair list about one step (0.1 %)."""
        t0 = time.perf_counter()
        overlap = self.max_overlap()
        self._warnings.overlap(self, overlap)
        self.timers["progress"] += time.perf_counter() - t0
        return overlap

    def _timed(self, stage: str, fn, *args) -> None:
        t0 = time.perf_counter()
        fn(*args)
        self.timers[stage] += time.perf_counter() - t0

"""How a run's state is put together: ``SimulationBuilder``, the part of ``Simulation`` that
builds it from a scene (or a checkpoint) and edits it; ``simulation.py`` runs it.

Stage: set-up. The order matters and is the one a reader follows in ``__init__``:

    the step and the contact model     resolve_step, options_for, history columns, StepOptions
    the compiled step loop             make_stepper (compiled once per set of effects)
    parameters                         Params: the law's, the rings', dt, skin, bottom friction
    memory check, placement            prepare_memory, initial_configuration (whole cell)
    decomposition                      the cut of the annulus among the ranks (one rank: serial)
    the in-situ averager               make_averager ([averaging]; None without)
    this rank's rows                   rank_share, or restore from a checkpoint (restart:
                                       the same scene; branch: other physics, branch.py)
    the output folder                  claim (after the checkpoint is read: a restart may
                                       write into the folder it came from)
    lists and forces                   the first neighbour build, then the forces at t
                                       (a checkpoint's recorded forces instead, bit for bit,
                                       unless a branch changed the physics)
"""

from __future__ import annotations

import functools
import math
import sys
from pathlib import Path

import numpy as np

from .compile_ahead import compile_ahead, compile_first
from .contact.history import live_history, tracks_eta
from .contact.model import history_columns, law_params, options_for
from .contact.pairs import pair_table
from .core.memory import prepare_memory, reuse_freed_arrays
from .core.neighbors import WALL_SKINS
from .core.rebuild import Rebuilder
from .core.state import Params, new_clock, new_pairs
from .core.step import StepOptions, make_stepper
from .core.timing import FIRST, Timing
from .core.timestep import resolve_step
from .input.placement import PLACEMENTS, initial_configuration, rank_share
from .input.scene import Scene, SceneError
from .output.averages import make_averager, resume
from .output.branch import branch_head
from .output.folder import FolderLock, claim
from .output.progress import breakdown, log_line
from .output.restart import put_recorded_forces, restore
from .parallel import GHOST_MARGIN_SKINS, decomposition
from .boundaries.registry import flat_surfaces, moving_disks
from .boundaries.walls import place_wall_disks, rings_of, wall_layout


class SimulationBuilder:
    """The state of one scene's run, built in the order above, and the ways to edit it
    between runs (``set_particles``, ``refresh``). ``Simulation`` adds the run loop.
    ``restart``: continue a checkpoint of this scene exactly; ``branch``: start from a
    checkpoint of a prepared run with this scene's material and drive (output/branch.py)."""

    def __init__(self, scene: Scene, out_dir: str | Path | None = None,
                 restart: str | Path | None = None, comm=None, overwrite: bool = False,
                 cut: str = "auto", branch: str | Path | None = None, timing: bool = False):
        if restart is not None and branch is not None:
            raise SceneError("--restart and --from: give one (--restart continues the same "
                             "scene, --from branches a new run off a prepared state)")
        self.scene = scene
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self._early: list[str] | None = []  # log lines before the folder is claimed (log)
        self.step_length = resolve_step(scene)  # exact (s): the clock is step x this
        self.dt = float(self.step_length)
        e, g = scene.effects, scene.geometry
        self.contact = options_for(e, scene.time.integrator, tracks_eta(scene, out_dir is not None),
                                   scene.contact, bool(scene.pairs))
        self.history_columns = history_columns(self.contact)
        self.hist = len(self.history_columns)
        self.options = StepOptions(self.contact, e.rotation, e.bottom_friction,
                                   flat_surfaces(scene),
                                   predict=scene.time.integrator == "verlet",
                                   timing=Timing(timing))
        self.stepper = make_stepper(self.options)
        self.timers = {"forces+integration": 0.0, "neighbour rebuild": 0.0, "averaging": 0.0,
                       "snapshots": 0.0, "checkpoints": 0.0, "progress": 0.0}
        self.n_rebuilds = 0
        skin = scene.neighbors.skin or 0.1 * scene.min_free_diameter
        c = scene.contact
        inner = g is not None and wall_layout(g, "inner").count > 0
        walled = moving_disks(scene)
        self.prm = Params(law_params(c, self.dt), rings_of(g), pair_table(scene, self.dt),
                          self.dt, skin, c.mu_bottom * c.gravity, math.inf,
                          wall_skin=WALL_SKINS * skin if walled else 0.0,
                          inner_disks=inner, wall_disks=walled)
        prepare_memory(scene, comm)
        init = initial_configuration(scene)
        self.n_free = init.n_free
        self._free_radii = init.radius[:init.n_free].copy()
        self.decomp = decomposition(comm, 2.0 * float(init.radius[:init.n_free].max()) + skin,
                                    g.inner_radius if g else 0.0,
                                    margin=GHOST_MARGIN_SKINS * skin, cut=cut)
        if init.placement == "inserted" and restart is None and branch is None:
            self._say(f"note: the {init.n_free} free disks were {PLACEMENTS['inserted']}")
        compile_first(self.decomp)  # parallel runs: the kernels the cut needs, shared
        self.clock = new_clock(init.n_free, init.radius.size, self.prm.rings.r_out0)
        # the in-situ averager ([averaging] table; None without), kept across run() calls
        self.rings = make_averager(scene, self._free_radii, self.decomp)
        history, recorded, exact = None, None, True
        self._series = None  # the snapshot numbering (output/series.py), from the first run
        self._end_step = None  # the checkpoint's step if its snapshot is an end snapshot
        if restart is None and branch is None:  # this rank's rows only, built or read
            self.ps, n_owned, n = rank_share(init, self.decomp, self.hist)
        else:
            head = None if branch is None else functools.partial(
                branch_head, step_length=self.step_length, log=self._say)
            try:
                got = restore(restart or branch, init, scene, self.dt, self.history_columns,
                              self.decomp, self.log, head)
            except SceneError as e:  # the checkpoint's checks name the option a restart has
                if branch is None:
                    raise
                text = str(e)  # only the option that opens the message: it may advise --restart
                raise SceneError("--from" + text[len("--restart"):] if text.startswith(
                    "--restart") else text) from e
            self.ps, n_owned, n, self.clock.step[0], history, recorded, averages, end = got[:8]
            self._end_step = self.step if end else None
            self.prm = self.prm._replace(rings=self.prm.rings._replace(phase_in=got.phase))
            exact = got.exact
            if branch is None:
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
        # no owned particle comes this close to an idle wall disk between exchanges
        self.wall_margin = self.decomp.ghost_width + self.prm.wall_skin + 2.0 * wall_radius
        self.pairs = new_pairs(4 * n + 64, max(n // 4, 64), self.hist)
        compile_ahead(self, history)  # parallel runs: the ranks share a cold compile
        self.rebuilder = Rebuilder(self)
        if not exact:  # a branch's rings turn at its omega from the angle they had reached
            place_wall_disks(self.ps, 0, n, self.clock_time, self.prm.rings, False)
        self.rebuilder.rebuild(history=history, rebalance=False)
        if restart is None and branch is None:
            self._compute_forces()
        elif exact:
            put_recorded_forces(self, *recorded)
        else:
            self._compute_forces(advance_history=False)
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
        """Steps taken since t = 0 (a restart or branch continues the count)."""
        return int(self.clock.step[0])

    def log(self, text: str) -> None:
        """Append a time-stamped line to DIR/log.txt (rank 0); kept until the folder is
        claimed, which a log.txt already written would make look like another run's."""
        if self._early is not None:
            self._early.append(text)
        elif self.decomp.rank == 0:
            log_line(self.out_dir, text)

    def _say(self, text: str) -> None:
        """``log`` and a line on stderr (rank 0): what a branch changed or could not keep."""
        self.log(text)
        if self.decomp.rank == 0:
            sys.stderr.write(f"pardem: {text}\n")

    def breakdown(self) -> str:
        """The wall time per stage as the table a run prints at its end."""
        return breakdown(self)

    def reset_timers(self) -> None:
        """Zero the stage timers (those of a ``timing`` step loop too), the waiting time and
        the build count (benchmarks)."""
        for key in self.timers:
            self.timers[key] = 0.0
        self.clock.deep[FIRST:] = 0.0
        self.rebuilder.exchange_seconds = 0.0
        self.decomp.wait[:] = 0.0
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
        self.rebuilder.rebuild()
        self._compute_forces()

    def _compute_forces(self, advance_history: bool = True) -> None:
        """The forces of the current state. ``advance_history=False``: the history is the
        current state's already (a branch's first state, whose springs the prepared run
        advanced to this step): the law sees a step of length 0, so the springs are only
        capped at the (new) Coulomb limit and projected, not moved on by v_t dt."""
        n = int(self.clock.n_local[0])
        v2 = float((self.ps.v[:n] ** 2).sum(axis=1).max()) if n else 0.0
        prm = self.prm if advance_history else self.prm._replace(
            law=self.prm.law._replace(dt=0.0))
        self.stepper.compute_forces(self.ps, self.pairs, self.clock, prm, self.decomp.halo,
                                    self.decomp.max(v2))

    # -- neighbour lists ----------------------------------------------------------------------
    def history_table(self):
        """This rank's non-zero contact history: (gid_lo, gid_hi, rows), sorted by key."""
        return live_history(self.ps.gid, self.pairs.i, self.pairs.j, self.pairs.hist,
                            int(self.pairs.count[0]))

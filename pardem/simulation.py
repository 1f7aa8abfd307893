"""``Simulation``: builds the state of a scene and runs it, firing writers between compiled chunks.

Stage: driver. The physics of one step is in ``stepper.py``; this module decides how many steps
each compiled call runs (up to the next snapshot, checkpoint or progress report), rebuilds the
neighbour list when the step loop asks for it, and keeps per-stage timers. Run loop:

    forces at t = 0 (or restore forces from the checkpoint)
    while step < end:
        status = advance(..., up to the next event)      # many steps in compiled code
        if status == NEED_REBUILD: rebuild neighbour list (carry springs), continue
        if status == BAD_PARTICLE: stop with the particle's id, time and position
        fire due writers (snapshot, checkpoint), print progress
    final checkpoint
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

from . import diagnostics as diag
from .contact import LawOptions
from .decomposition import GHOST_MARGIN_SKINS, Decomposition
from .migration import merge_springs
from .neighbors import build_lists, live_springs
from .output.checkpoint import ARRAYS, load_checkpoint, save_checkpoint
from .output.snapshots import write_snapshot
from .placement import initial_configuration
from .scene import Scene, SceneError, write_scene
from .state import (FREE, NO_SPRINGS, Params, history_width, new_clock, new_pairs,
                    new_particles, packed, row_width, unpack_particles)
from .stepper import BAD_PARTICLE, MPI_FAILED, NEED_REBUILD, StepOptions, make_stepper
from .timestep import resolve_dt
from .walls import arrange_walls, outer_radius, place_wall_disks, wall_layout


class SimulationError(RuntimeError):
    """The run became invalid (non-finite value, particle left the cell)."""


def tracks_eta(scene: Scene, writes_output: bool) -> bool:
    """Whether a run keeps the paper's total tangential displacement eta (eq. 1.3) per contact:
    only with tangential friction (without it no tangential history is kept), and only where
    something reads it: in-situ averaging with [averaging] displacement = "eta" (the default),
    or contacts written with the snapshots (``writes_output``; offline averaging may use either
    displacement). Otherwise the step loop is compiled without it and costs nothing extra."""
    if not scene.effects.tangential_friction:
        return False
    avg = scene.averaging
    return ((writes_output and scene.output.contacts)
            or (avg is not None and scene.geometry is not None and avg.displacement == "eta"))


class Simulation:
    """One scene's state and run loop.

    ``Simulation(scene, out_dir=None, restart=None)``; ``run(end=None, progress=True)``.
    Attributes: ``ps`` (Particles), ``pairs`` (Pairs), ``clock`` (Clock), ``prm`` (Params),
    ``dt`` (s), ``time`` (s), ``timers`` (s per stage), ``n_rebuilds``.

    With ``comm`` (an mpi4py communicator), every method that advances or gathers is
    collective. An exception on one rank leaves the others waiting in the next collective or
    ghost refresh: a caller must then abort the communicator (``pardem run`` calls
    ``MPI_Abort``; the tests' conftest does the same).
    """

    def __init__(self, scene: Scene, out_dir: str | Path | None = None,
                 restart: str | Path | None = None, comm=None):
        self.scene = scene
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self.dt = resolve_dt(scene)
        e = scene.effects
        self.friction = e.tangential_friction
        self.eta = tracks_eta(scene, out_dir is not None)
        self.hist = history_width(self.friction, self.eta)
        self.options = StepOptions(
            LawOptions(e.normal_damping, e.tangential_friction, e.clip_attractive_normal),
            e.rotation, e.bottom_friction, scene.info.kind == "couette",
            predict=scene.time.integrator == "verlet", eta=self.eta)
        self.stepper = make_stepper(self.options)
        self.timers = {"forces+integration": 0.0, "neighbour rebuild": 0.0, "averaging": 0.0,
                       "snapshots": 0.0, "checkpoints": 0.0, "progress": 0.0}
        self.rings = None  # the in-situ RingAverager ([averaging] table), kept across run() calls
        self.n_rebuilds = 0
        g = scene.geometry
        c = scene.contact
        skin = scene.neighbors.skin or 0.1 * scene.min_free_diameter
        init = initial_configuration(scene)
        self.prm = Params(
            dt=self.dt, k_n=c.k_n, gamma_n=c.gamma_n, k_t=c.k_t, mu=c.mu,
            mu_b_g=c.mu_bottom * c.gravity,
            r_in=g.inner_radius if g else 0.0, omega_in=g.omega_inner if g else 0.0,
            r_out=g.outer_radius if g else 0.0, r_out0=g.outer_start_radius if g else 0.0,
            t_comp=g.compression_time if g else 0.0, skin=skin,
            escape_radius=math.inf,
            flat_in=float(wall_layout(g, "inner").flat) if g else 1.0,
            flat_out=float(wall_layout(g, "outer").flat) if g else 1.0)
        self.n_free = init.n_free
        self._free_radii = init.radius[:init.n_free].copy()
        self.decomp = Decomposition(comm, 2.0 * float(init.radius[:init.n_free].max()) + skin,
                                    g.inner_radius if g else 0.0,
                                    margin=GHOST_MARGIN_SKINS * skin)
        # Every rank builds the whole initial state (cheap, deterministic), then keeps its share.
        n = init.radius.size
        ps = new_particles(n, self.hist)
        ps.gid[:] = np.arange(n)
        ps.kind[:] = init.kind
        ps.x[:] = init.x
        ps.v[:] = init.v
        ps.omega[:] = init.omega
        ps.radius[:] = init.radius
        ps.mass[:] = init.mass
        ps.inv_mass[:] = 1.0 / init.mass
        ps.inv_inertia[:] = 2.0 / (init.mass * init.radius**2)  # I = m d^2 / 8
        ps.phi0[:] = init.phi0
        ps.e0[:] = np.column_stack([np.cos(init.phi0), np.sin(init.phi0)])
        self.clock = new_clock(init.n_free, n, self.prm.r_out0)
        history = None
        if restart is not None:
            history = self._restore(ps, restart)
        self.decomp.place_sectors(ps.x[:init.n_free])
        owner = self.decomp.sectors.owner(ps.x[:init.n_free])
        mine = np.flatnonzero(owner == self.decomp.rank)
        rows = packed(ps, np.concatenate([mine, np.arange(init.n_free, n)]), self.hist)
        self.ps = new_particles(rows.shape[0], self.hist)
        unpack_particles(rows, self.ps, 0)
        self.clock.n_move[0] = mine.size
        self.clock.n_local[0] = rows.shape[0]
        self.clock.n_moved[0] = rows.shape[0]  # every wall disk is at time t: none idle yet
        # _order_walls: no owned particle gets this close to an idle wall disk between exchanges
        self._wall_margin = self.decomp.ghost_width + 2.0 * float(
            init.radius[init.n_free:].max(initial=0.0))
        self.pairs = new_pairs(4 * n + 64, max(n // 4, 64), self.hist)
        self._rebuild(history=history, rebalance=False)
        if restart is None:
            self._compute_forces()

    def refresh(self) -> None:
        """Rebuild the neighbour list and recompute forces after the state was edited by hand
        (tests, prepared initial conditions). Springs of pairs that still touch are kept."""
        self._rebuild()
        self._compute_forces()

    def _compute_forces(self) -> None:
        n = int(self.clock.n_local[0])
        v2 = float((self.ps.v[:n] ** 2).sum(axis=1).max()) if n else 0.0
        self.stepper.compute_forces(self.ps, self.pairs, self.clock, self.prm, self.decomp.max(v2))

    @property
    def time(self) -> float:
        return float(self.clock.step[0] * self.dt)

    # -- neighbour list -------------------------------------------------------------------
    def _rebuild(self, history=None, rebalance: bool = True, exchange: bool = True) -> None:
        """New neighbour list; under MPI, if ``exchange``, first migrate particles and
        exchange ghosts (which usually builds the lists too). Springs are carried over by gid
        keys (from ``history`` if given, else from the current list)."""
        count, n_wall = -1, -1  # lists not built yet
        if self.decomp.parallel and exchange:
            history, (count, n_wall) = self._exchange(history, rebalance)
        from_list = self.friction and history is None
        lo, hi, xi = history if history is not None else NO_SPRINGS
        while not (0 <= count <= self.pairs.i.size and 0 <= n_wall <= self.pairs.wall.size):
            if count >= 0:  # a build overflowed the lists: grow them, keep the springs read
                from_list = False
                self.pairs = new_pairs(max(count + count // 2, self.pairs.i.size),
                                       max(n_wall + n_wall // 2, self.pairs.wall.size),
                                       self.hist)
            count, n_wall, lo, hi, xi = build_lists(
                self.ps, self.pairs, self.clock, self.prm, self.time, from_list, lo, hi, xi,
                self.friction, self.options.walls)
        self.n_rebuilds += 1

    def _exchange(self, history, rebalance: bool):
        """Under MPI: migrate owned particles that left the sector, exchange ghosts, lay the
        rows out again as [owned | wall disks | ghosts] and, if they fit, build the lists. If
        nothing migrated, the owned rows and wall disks stay where they are and only the ghost
        rows are written. Returns the spring history with the migrants'
        springs merged in, and (pair count, ring candidate count) of the lists, or (-1, -1)
        if they were not built."""
        clock, ps, hist = self.clock, self.ps, self.hist
        n_move, n_local = int(clock.n_move[0]), int(clock.n_local[0])
        idle = n_local - int(clock.n_moved[0])  # wall disks not moved since the last build
        if rebalance:
            self.decomp.rebalance(ps.x[:n_move])
        written, moved, own, walls, ghosts, lists, history = self.decomp.distribute(
            ps, self.pairs, clock, n_move, n_local, idle, hist, self.options.walls, history,
            self.time, self.prm, self._wall_margin)
        if not written:  # ps too small: store the rows in larger arrays
            rows = np.concatenate([own, walls, ghosts] if moved else
                                  [packed(ps, np.arange(n_local), hist), ghosts])
            self.ps = ps = new_particles(int(1.25 * rows.shape[0]), hist)
            unpack_particles(rows, ps, 0)
            self._order_walls(idle)  # the wall block keeps its order: the idle ones are last
        return history, lists

    def _order_walls(self, idle: int) -> None:
        """Store the wall disks near this rank's sector first and let the step loop move only
        those (clock.n_moved): on 2 ranks the other half of the ~320 wall disks cost ~1 us per
        step for nothing. "Near": within the ghost width plus a wall diameter of the sector, so
        no owned particle can touch another wall disk before the next exchange (until then
        each body moves at most half the ghost margin plus the half skin that triggers a
        build, see Decomposition.exchange_due: well inside the margin). Every wall
        disk lies in some sector, so the ranks together still move all of them and the
        per-step maxima stay global. Redone at every exchange:
        the inner ring carries its disks from sector to sector. ``idle``: how many wall disks,
        stored last, the step loop did not move (placed here first)."""
        clock, ps = self.clock, self.ps
        n_move, n_local = int(clock.n_move[0]), int(clock.n_local[0])
        n_near = arrange_walls(ps, n_move, n_local - idle, n_local, self.time, self.prm,
                               self.decomp.sectors.edges, self.decomp.rank, self._wall_margin,
                               row_width(self.hist))
        clock.n_moved[0] = n_move + n_near

    def _place_idle_walls(self) -> None:
        """Bring the wall disks the step loop does not move (clock.n_moved onwards) to the
        current time whenever control returns to Python (output, diagnostics and checkpoints
        see every wall disk where it is; exchanges place them in ``arrange_walls``). Builds
        that do not exchange leave them where they are: no owned particle is near them."""
        first, last = int(self.clock.n_moved[0]), int(self.clock.n_local[0])
        if last > first:
            place_wall_disks(self.ps, first, last, self.time, self.prm, False)

    def _spring_history(self):
        """Springs of the current list that are non-zero, keyed by (gid_lo, gid_hi), sorted."""
        return live_springs(self.ps.gid, self.pairs.i, self.pairs.j, self.pairs.xi,
                            int(self.pairs.count[0]))

    # -- running ---------------------------------------------------------------------------
    def run(self, end: float | None = None, progress: bool = True) -> None:
        """Advance to time ``end`` (s; default the scene's [time] end), writing snapshots and
        checkpoints into ``out_dir`` (if set) and a progress line to stderr (rank 0). Under MPI
        every rank calls this; chunk sizes and report times are rank 0's decisions."""
        end = self.scene.time.end if end is None else end
        end_step = int(round(end / self.dt))
        out = self.scene.output
        snap_every = max(1, int(round(out.snapshot_interval / self.dt)))
        ckpt_every = max(1, int(round(out.checkpoint_interval / self.dt)))
        root = self.decomp.rank == 0
        if self.out_dir is not None:
            if root:
                self.out_dir.mkdir(parents=True, exist_ok=True)
                write_scene(self.scene, self.out_dir / "scene.toml")
            self.log(f"run {self.scene.info.name}: t = {self.time:.6g} s to {end:.6g} s, "
                     f"{self.n_free} particles, dt = {self.dt:.6g} s, {self.decomp.describe()}")
            if self.clock.step[0] % snap_every == 0:
                self._timed("snapshots", self.write_snapshot)
        rings, avg_steps = self._ring_averager(end_step)
        avg_set = set(avg_steps.tolist())
        wall0, step0 = time.perf_counter(), int(self.clock.step[0])
        chunk, last_report = 1000, 0.0
        while self.clock.step[0] < end_step:
            step = int(self.clock.step[0])
            target = min(end_step, (step // snap_every + 1) * snap_every,
                         (step // ckpt_every + 1) * ckpt_every, step + chunk)
            upcoming = avg_steps[np.searchsorted(avg_steps, step, side="right"):]
            if upcoming.size:
                target = min(target, int(upcoming[0]))
            t0 = time.perf_counter()
            self._advance_to(target)
            t1 = time.perf_counter()
            done = int(self.clock.step[0]) - step
            if t1 - t0 > 0 and done > 0:  # aim at ~0.25 s of compiled work per call
                chunk = int(min(max(done * 0.25 / (t1 - t0), 100), 1_000_000))
            step = int(self.clock.step[0])
            every = 1.0 if progress else (10.0 if self.out_dir is not None else math.inf)
            report = t1 - last_report > every or (step >= end_step and every < math.inf)
            chunk, report = self.decomp.bcast((chunk, report))
            if step in avg_set:
                self._timed("averaging", rings.sample, self)
            if self.out_dir is not None:
                if step % snap_every == 0:
                    self._timed("snapshots", self.write_snapshot)
                if step % ckpt_every == 0:
                    self._timed("checkpoints", self.write_checkpoint)
            if report:
                last_report = t1
                self._timed("progress", self._report, wall0, step0, end_step, progress)
        if self.out_dir is not None:
            if self.clock.step[0] % snap_every:  # the final state, off the snapshot grid
                self._timed("snapshots", self.write_snapshot)
            self._timed("checkpoints", self.write_checkpoint)
            if rings is not None and rings.samples and root:
                self._timed("averaging", rings.write, self.out_dir)
        self.rings = rings
        self.log(self.breakdown())
        if progress and root:
            sys.stderr.write("\n" + self.breakdown() + "\n")

    def _ring_averager(self, end_step: int):
        """The in-situ ring averager of the scene's [averaging] table (None without one) and its
        sampling steps: the multiples of round(sample_interval/dt) nearest to start .. end (the
        snapshot rule, so offline averaging of snapshots sees the same states)."""
        cfg, g = self.scene.averaging, self.scene.geometry
        if cfg is None or g is None:
            return None, np.zeros(0, np.int64)
        from averaging.rings import RingAverager  # averaging builds on pardem, not vice versa

        steps = sample_steps(cfg.start, cfg.end, cfg.sample_interval, self.dt)
        steps = steps[(steps <= end_step) & (steps > int(self.clock.step[0]))]
        if self.rings is not None:  # a later run() call continues the same time average
            return self.rings, steps
        d_ref = cfg.reference_diameter or 2.0 * float(np.mean(self._free_radii))
        avg = RingAverager(g.inner_radius, g.outer_radius, cfg.ring_width, cfg.weighting,
                           self.scene.contact.height, d_ref, self.scene.contact.k_n,
                           g.omega_inner, self.decomp.comm)
        return avg, steps

    def advance_steps(self, n: int) -> None:
        """Take n steps without output (tests, benchmarks); collective under MPI."""
        self._advance_to(int(self.clock.step[0]) + n)

    def _advance_to(self, target: int) -> None:
        while True:
            t0 = time.perf_counter()
            status, bad = self.stepper.advance(self.ps, self.pairs, self.clock, self.prm,
                                               self.decomp.halo, target)
            t1 = time.perf_counter()
            self.timers["forces+integration"] += t1 - t0
            if status == NEED_REBUILD:  # every rank returns at the same step (global maxima)
                self._rebuild(exchange=self.decomp.exchange_due(float(self.clock.disp[0])))
                self.timers["neighbour rebuild"] += time.perf_counter() - t1
            elif status == BAD_PARTICLE:
                message = self._bad_particle_message(bad) if bad >= 0 else None
                message = self.decomp.first_message(message)
                self.log(f"run stopped: {message}")
                raise SimulationError(message)
            elif status == MPI_FAILED:
                raise RuntimeError(f"MPI ghost exchange failed on rank {self.decomp.rank} at "
                                   f"step {int(self.clock.step[0])}")
            else:
                self._place_idle_walls()
                return

    def _timed(self, stage: str, fn, *args) -> None:
        t0 = time.perf_counter()
        fn(*args)
        self.timers[stage] += time.perf_counter() - t0

    def _report(self, wall0: float, step0: int, end_step: int, progress: bool) -> None:
        e_kin, overlap = self.kinetic_energy(), self.max_overlap()  # collective
        if self.decomp.rank != 0:
            return
        step = int(self.clock.step[0])
        elapsed = time.perf_counter() - wall0
        rate = (step - step0) / elapsed if elapsed > 0 else 0.0
        eta = (end_step - step) / rate if rate > 0 else math.inf
        line = (f"t = {self.time:9.3f} / {end_step * self.dt:.3f} s | {rate:9.0f} steps/s | "
                f"{rate * self.n_free / 1e6:6.2f} M particle-steps/s | ETA {eta:7.1f} s | "
                f"E_kin {e_kin:.3e} J | max overlap {100 * overlap:.2f}% d")
        self.log(line)
        if progress:
            sys.stderr.write("\r" + line + " ")
            sys.stderr.flush()

    def log(self, text: str) -> None:
        """Append a time-stamped line to DIR/log.txt (rank 0; opened and closed each time, so
        a crash loses nothing already logged; a restart appends to the same log)."""
        if self.out_dir is None or self.decomp.rank != 0:
            return
        stamp = time.strftime("%Y-%m-%d %H:%M:%S")
        self.out_dir.mkdir(parents=True, exist_ok=True)
        with open(self.out_dir / "log.txt", "a") as f:
            f.write(f"{stamp} {text}\n")

    def breakdown(self) -> str:
        total = sum(self.timers.values()) or 1.0
        rows = [f"  {k:<20s} {v:9.3f} s  {100 * v / total:5.1f} %" for k, v in self.timers.items()]
        if self.decomp.parallel:  # part of forces+integration
            wait = float(self.decomp.halo.wait[0])
            rows.insert(1, f"    of which waiting on neighbours {wait:9.3f} s  "
                           f"{100 * wait / total:5.1f} % (exchange latency + imbalance)")
        steps = int(self.clock.step[0])
        builds = f"{self.n_rebuilds} neighbour builds"
        if self.decomp.parallel:
            builds += f", {self.decomp.n_exchanges} of them with an exchange"
        return "\n".join([f"time per stage on rank {self.decomp.rank} ({steps} steps, "
                          f"{builds}; {self.decomp.describe()}):",
                          *rows])

    def _bad_particle_message(self, k: int) -> str:
        ps = self.ps
        x, ref = ps.x[k], ps.x_ref[k]
        return (f"particle id {int(ps.gid[k])} became invalid at t = {self.time:.6f} s (step "
                f"{int(self.clock.step[0])}): position ({x[0]:.6g}, {x[1]:.6g}) m, velocity "
                f"({ps.v[k, 0]:.6g}, {ps.v[k, 1]:.6g}) m/s (non-finite, or outside the cell; "
                f"at the last neighbour-list build it was at ({ref[0]:.6g}, {ref[1]:.6g}) m); "
                "the last checkpoint is kept")

    # -- measurements (collective under MPI: every rank must call them) ----------------------
    def kinetic_energy(self) -> float:
        return float(self.decomp.sum(diag.kinetic_energy(self.ps, int(self.clock.n_move[0]))))

    def total_energy(self) -> float:
        """Kinetic + elastic energy (J): disk-disk springs and flat-ring springs."""
        n_move = int(self.clock.n_move[0])
        e = diag.elastic_energy(self.ps, self.pairs, self.prm, n_move)
        if self.options.walls:
            r_out = outer_radius(self.time, self.prm)[0]
            e += diag.ring_elastic_energy(self.ps, self.pairs, self.prm, r_out)
        return self.kinetic_energy() + float(self.decomp.sum(e))

    def max_overlap(self) -> float:
        """Largest overlap over the diameter of the smaller free particle in the contact."""
        r_out = outer_radius(self.time, self.prm)[0]
        return float(self.decomp.max(diag.max_overlap_ratio(self.ps, self.pairs, self.prm, r_out)))

    def _local_contacts(self) -> dict[str, np.ndarray]:
        """Contacts whose lower-gid partner this rank owns (so each is reported once)."""
        e = self.scene.effects
        self.sync_ghost_velocities()
        return diag.contact_table(self.ps, self.pairs, self.prm, self.friction,
                                  e.normal_damping, int(self.clock.n_move[0]))

    def sync_ghost_velocities(self) -> None:
        """Give the ghosts their owners' current v and omega (collective; the step loop refreshes
        only what the forces need, so output and diagnostics call this first)."""
        if self.decomp.parallel:
            first = int(self.clock.n_local[0])
            n_move, n_ghost = int(self.clock.n_move[0]), int(self.clock.n_ghost[0])
            both = self.decomp.ghost_values(
                np.column_stack([self.ps.v[:n_move], self.ps.omega[:n_move]]))
            self.ps.v[first:first + n_ghost] = both[:, :2]
            self.ps.omega[first:first + n_ghost] = both[:, 2]

    def contacts(self) -> dict[str, np.ndarray] | None:
        """Touching pairs of the whole cell sorted by (gid_lo, gid_hi) (diagnostics.contact_table
        columns); on rank 0 only (None on the others)."""
        return self.decomp.gather_rows(self._local_contacts(), key="ids")

    def ring_contacts(self) -> dict[str, np.ndarray] | None:
        """Contacts of free particles with the flat ring surfaces, sorted by particle id
        (diagnostics.ring_contact_table columns without ``index``); rank 0 only."""
        r_out, rate = outer_radius(self.time, self.prm)
        e = self.scene.effects
        t = diag.ring_contact_table(self.ps, self.pairs, self.prm, r_out, rate, self.friction,
                                    e.normal_damping)
        del t["index"]
        return self.decomp.gather_rows(t, key="id")

    def particle_arrays(self) -> dict[str, np.ndarray] | None:
        """Particle data of the whole cell sorted by id (the snapshot layout); rank 0 only."""
        return self._particle_table(self.contacts())

    def _particle_table(self, contacts: dict[str, np.ndarray] | None):
        """particle_arrays() given this instant's gathered contacts (collective)."""
        ps, n_move = self.ps, int(self.clock.n_move[0])
        rows = slice(0, int(self.clock.n_local[0]) if self.decomp.rank == 0 else n_move)
        mine = {"id": ps.gid[rows], "kind": ps.kind[rows], "position": ps.x[rows],
                "velocity": ps.v[rows], "omega": ps.omega[rows], "theta": ps.theta[rows],
                "radius": ps.radius[rows], "mass": ps.mass[rows], "force": ps.f[rows],
                "torque": ps.tau[rows]}
        mine["rank"] = np.full(mine["id"].size, self.decomp.rank, np.int32)
        mine["rank"][n_move:] = -1  # wall disks: prescribed, every rank holds all of them
        out = self.decomp.gather_rows(mine, key="id")
        if out is None:
            return None
        _clear_wall_loads(out, "kind", "force", "torque")
        ids = contacts["ids"]
        out["coordination"] = np.bincount(np.searchsorted(out["id"], ids.ravel()),
                                          minlength=out["id"].size)
        return out

    # -- output ---------------------------------------------------------------------------------
    def write_snapshot(self) -> None:
        every = max(1, int(round(self.scene.output.snapshot_interval / self.dt)))
        contacts = self.contacts()
        ring = self.ring_contacts() if self.options.walls and self.scene.output.contacts else None
        arrays = self._particle_table(contacts)
        if self.decomp.rank == 0:
            # off-grid (final) states take the next index, which the next run overwrites
            write_snapshot(self.out_dir, -(-int(self.clock.step[0]) // every), self.time,
                           int(self.clock.step[0]), arrays,
                           contacts if self.scene.output.contacts else None, ring)

    def checkpoint_state(self) -> tuple[dict[str, np.ndarray], dict[str, object]] | None:
        """The whole state gathered on rank 0 (None on the others), sorted by gid."""
        ps, n_move = self.ps, int(self.clock.n_move[0])
        rows = slice(0, int(self.clock.n_local[0]) if self.decomp.rank == 0 else n_move)
        mine = {k: getattr(ps, k)[rows] for k in ARRAYS if k != "xi_wall" or self.friction}
        arrays = self.decomp.gather_rows(mine)
        springs = self._spring_history() if self.friction else None
        if self.friction and self.decomp.parallel:
            gathered = self.decomp.gather_rows(
                {"key": np.column_stack(springs[:2]), "xi": springs[2]}, key="key")
            key = None if gathered is None else np.ascontiguousarray(gathered["key"].T)
            springs = None if gathered is None else merge_springs(
                key[0], key[1], gathered["xi"], np.zeros((0, 2 + self.hist)))
        if arrays is None:
            return None
        _clear_wall_loads(arrays, "kind", "f", "tau")
        if not self.friction:
            arrays["xi_wall"] = np.zeros((0, 2))
        arrays["pair_lo"] = springs[0] if springs else np.zeros(0, np.int64)
        arrays["pair_hi"] = springs[1] if springs else np.zeros(0, np.int64)
        arrays["pair_xi"] = springs[2] if springs else np.zeros((0, 2))
        attrs = {"step": int(self.clock.step[0]), "time": self.time, "dt": self.dt,
                 "ring_angle": self.prm.omega_in * self.time,
                 "fingerprint": self.scene.fingerprint(), "n_free": self.n_free,
                 "ranks": self.decomp.size}
        return arrays, attrs

    def write_checkpoint(self, path: str | Path | None = None) -> None:
        state = self.checkpoint_state()
        if state is not None:
            save_checkpoint(path or self.out_dir / "checkpoint.h5", *state)

    def _restore(self, ps, path: str | Path):
        """Fill the whole-cell arrays ps from a checkpoint (read on rank 0, sent to all);
        returns the spring history."""
        arrays, attrs = self.decomp.bcast_call(load_checkpoint, path)
        if attrs["fingerprint"] != self.scene.fingerprint():
            raise SceneError(f"--restart {path}: the checkpoint belongs to a different scene "
                             "(geometry, particles, contact law, effects or dt differ)")
        if attrs["dt"] != self.dt:
            raise SceneError(f"--restart {path}: checkpoint dt = {attrs['dt']} s differs from "
                             f"the scene's dt = {self.dt} s")
        n = ps.gid.size
        if arrays["gid"].size != n:
            raise SceneError(f"--restart {path}: {arrays['gid'].size} particles in the "
                             f"checkpoint, {n} in the scene")
        _check_restored(path, arrays, ps)
        if self.friction:
            for k in ("xi_wall", "pair_xi"):
                arrays[k] = self._history_columns(path, arrays[k])
        for k in ARRAYS:
            getattr(ps, k)[: arrays[k].shape[0]] = arrays[k]
        self.clock.step[0] = int(attrs["step"])
        return (arrays["pair_lo"], arrays["pair_hi"], arrays["pair_xi"]) if self.friction else None

    def _history_columns(self, path, xi: np.ndarray) -> np.ndarray:
        """A checkpoint's history (spring, eta if it tracked it) with this run's columns: eta
        dropped if this run does not track it; if it does and the checkpoint has none, eta
        starts as the spring, which is exact for every contact that has not slid (logged)."""
        xi = np.asarray(xi, float)
        if xi.ndim != 2 or xi.shape[1] not in (2, 4):
            raise SceneError(f"--restart {path}: corrupted checkpoint: tangential history of "
                             f"shape {xi.shape} (rows x 2 or rows x 4 expected)")
        if xi.shape[1] == self.hist:
            return xi
        if self.hist == 2:
            return np.ascontiguousarray(xi[:, :2])
        self.log(f"restart from {path}: the checkpoint has no eta (total tangential "
                 "displacement); it starts from the spring, exact for contacts that have not slid")
        return np.column_stack([xi, xi])


def _check_restored(path, arrays: dict[str, np.ndarray], ps) -> None:
    """A checkpoint whose bytes were damaged may still read as HDF5 (it has no checksums): its
    particles must be the scene's (ids, kinds, radii, masses: bit for bit) and every state value
    finite, else the restart is refused instead of continuing from garbage."""
    for key in ("gid", "kind", "radius", "mass"):
        bad = np.flatnonzero(np.asarray(arrays[key]) != getattr(ps, key))
        if bad.size:
            raise SceneError(f"--restart {path}: corrupted checkpoint: {key} of particle row "
                             f"{int(bad[0])} is {arrays[key][bad[0]]!r}, the scene has "
                             f"{getattr(ps, key)[bad[0]]!r}")
    for key in ("x", "v", "theta", "omega", "f", "tau", "xi_wall", "pair_xi"):
        bad = np.flatnonzero(~np.isfinite(np.asarray(arrays[key], float)).reshape(
            len(arrays[key]), -1).all(axis=1)) if len(arrays[key]) else []
        if len(bad):
            raise SceneError(f"--restart {path}: corrupted checkpoint: non-finite {key} in row "
                             f"{int(bad[0])}")
    lo, hi = np.asarray(arrays["pair_lo"]), np.asarray(arrays["pair_hi"])
    if lo.size and not (np.all(lo < hi) and lo.min() >= 0 and hi.max() < ps.gid.size):
        raise SceneError(f"--restart {path}: corrupted checkpoint: spring keys are not pairs "
                         f"of particle ids 0..{ps.gid.size - 1}")


def _clear_wall_loads(arrays: dict[str, np.ndarray], kind: str, force: str, torque: str) -> None:
    """Wall disks are prescribed: each rank adds only its own particles' contacts to them, so
    their force and torque are not a state; report 0 (ring loads come from the contact table)."""
    walls = arrays[kind] != FREE
    arrays[force][walls] = 0.0
    arrays[torque][walls] = 0.0


def sample_steps(start: float, end: float, interval: float, dt: float) -> np.ndarray:
    """Steps k * every (every = round(interval/dt)) for k from round(start/(every dt)) to
    round(end/(every dt)): evenly spaced samples that coincide with snapshots of that interval."""
    every = max(1, int(round(interval / dt)))
    k0 = int(round(start / (every * dt)))
    k1 = int(round(end / (every * dt))) if math.isfinite(end) else k0 - 1
    return every * np.arange(k0, k1 + 1, dtype=np.int64)

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
from .neighbors import build_pairs, carry_history, ring_candidates
from .output.checkpoint import ARRAYS, load_checkpoint, save_checkpoint
from .output.snapshots import write_snapshot
from .placement import initial_configuration
from .scene import Scene, SceneError, write_scene
from .state import Pairs, Params, new_clock, new_pairs, new_particles
from .stepper import BAD_PARTICLE, NEED_REBUILD, StepOptions, make_stepper
from .timestep import resolve_dt
from .walls import outer_radius


class SimulationError(RuntimeError):
    """The run became invalid (non-finite value, particle left the cell)."""


class Simulation:
    """One scene's state and run loop.

    ``Simulation(scene, out_dir=None, restart=None)``; ``run(end=None, progress=True)``.
    Attributes: ``ps`` (Particles), ``pairs`` (Pairs), ``clock`` (Clock), ``prm`` (Params),
    ``dt`` (s), ``time`` (s), ``timers`` (s per stage), ``n_rebuilds``.
    """

    def __init__(self, scene: Scene, out_dir: str | Path | None = None,
                 restart: str | Path | None = None, comm=None):
        if comm is not None and comm.Get_size() > 1:
            raise NotImplementedError("the MPI sector decomposition is not implemented yet")
        self.scene = scene
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self.dt = resolve_dt(scene)
        e = scene.effects
        self.friction = e.tangential_friction
        self.options = StepOptions(
            LawOptions(e.normal_damping, e.tangential_friction, e.clip_attractive_normal),
            e.rotation, e.bottom_friction, scene.info.kind == "couette")
        self.stepper = make_stepper(self.options)
        self.timers = {"forces+integration": 0.0, "neighbour rebuild": 0.0, "snapshots": 0.0,
                       "checkpoints": 0.0, "progress": 0.0}
        self.n_rebuilds = 0
        init = initial_configuration(scene)
        n = init.radius.size
        ps = new_particles(n, self.friction)
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
        self.ps = ps
        g = scene.geometry
        c = scene.contact
        skin = scene.neighbors.skin or 0.1 * scene.min_free_diameter
        self.prm = Params(
            dt=self.dt, k_n=c.k_n, gamma_n=c.gamma_n, k_t=c.k_t, mu=c.mu,
            mu_b_g=c.mu_bottom * c.gravity,
            r_in=g.inner_radius if g else 0.0, omega_in=g.omega_inner if g else 0.0,
            r_out=g.outer_radius if g else 0.0, r_out0=g.outer_start_radius if g else 0.0,
            t_comp=g.compression_time if g else 0.0, skin=skin,
            escape_radius=g.outer_start_radius + 0.5 * g.wall_particle_diameter if g else math.inf)
        self.n_free = init.n_free
        self.clock = new_clock(init.n_free, n, self.prm.r_out0)
        self.pairs = new_pairs(4 * n + 64, max(n // 4, 64), self.friction)
        if restart is not None:
            self._restore(restart)
        else:
            self._rebuild()
            self.stepper.compute_forces(self.ps, self.pairs, self.clock, self.prm)

    def refresh(self) -> None:
        """Rebuild the neighbour list and recompute forces after the state was edited by hand
        (tests, prepared initial conditions). Springs of pairs that still touch are kept."""
        self._rebuild()
        self.stepper.compute_forces(self.ps, self.pairs, self.clock, self.prm)

    @property
    def time(self) -> float:
        return float(self.clock.step[0] * self.dt)

    # -- neighbour list -------------------------------------------------------------------
    def _rebuild(self, old_keys=None) -> None:
        ps, pairs, clock = self.ps, self.pairs, self.clock
        n = int(clock.n_local[0])
        if old_keys is None and self.friction:
            c = int(pairs.count[0])
            old_keys = (ps.gid[pairs.i[:c]], ps.gid[pairs.j[:c]], pairs.xi[:c].copy())
        ps.x_ref[:n] = ps.x[:n]
        r_out_now = outer_radius(self.time, self.prm)[0]
        clock.r_out_ref[0] = r_out_now
        count = build_pairs(ps.x, ps.radius, ps.gid, ps.kind, n, self.prm.skin, pairs.i, pairs.j)
        if count > pairs.i.size:
            pairs = self._grow_pairs(count + count // 2, pairs.wall.size)
            build_pairs(ps.x, ps.radius, ps.gid, ps.kind, n, self.prm.skin, pairs.i, pairs.j)
        if self.friction:
            carry_history(*old_keys, ps.gid[pairs.i[:count]], ps.gid[pairs.j[:count]],
                          pairs.xi[:count])
        if not self.options.walls:
            pairs.count[0] = count
        else:
            nw = ring_candidates(ps.x, ps.radius, int(clock.n_move[0]), self.prm.r_in,
                                 r_out_now, self.prm.skin, pairs.wall)
            if nw > pairs.wall.size:
                pairs = self._grow_pairs(pairs.i.size, nw + nw // 2, keep=count)
                ring_candidates(ps.x, ps.radius, int(clock.n_move[0]), self.prm.r_in,
                                r_out_now, self.prm.skin, pairs.wall)
            pairs.wall_count[0] = nw
        pairs.count[0] = count
        self.n_rebuilds += 1

    def _grow_pairs(self, cap: int, wall_cap: int, keep: int = 0) -> Pairs:
        new = new_pairs(cap, wall_cap, self.friction)
        for a, b in zip(new[:3], self.pairs[:3]):
            a[:keep] = b[:keep]
        self.pairs = new
        return new

    # -- running ---------------------------------------------------------------------------
    def run(self, end: float | None = None, progress: bool = True) -> None:
        """Advance to time ``end`` (s; default the scene's [time] end), writing snapshots and
        checkpoints into ``out_dir`` (if set) and a progress line to stderr."""
        end = self.scene.time.end if end is None else end
        end_step = int(round(end / self.dt))
        out = self.scene.output
        snap_every = max(1, int(round(out.snapshot_interval / self.dt)))
        ckpt_every = max(1, int(round(out.checkpoint_interval / self.dt)))
        if self.out_dir is not None:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            write_scene(self.scene, self.out_dir / "scene.toml")
            if self.clock.step[0] % snap_every == 0:
                self._timed("snapshots", self.write_snapshot)
        wall0, step0 = time.perf_counter(), int(self.clock.step[0])
        chunk, last_report = 1000, 0.0
        while self.clock.step[0] < end_step:
            step = int(self.clock.step[0])
            target = min(end_step, (step // snap_every + 1) * snap_every,
                         (step // ckpt_every + 1) * ckpt_every, step + chunk)
            t0 = time.perf_counter()
            self._advance_to(target)
            t1 = time.perf_counter()
            done = int(self.clock.step[0]) - step
            if t1 - t0 > 0 and done > 0:  # aim at ~0.25 s of compiled work per call
                chunk = int(min(max(done * 0.25 / (t1 - t0), 100), 1_000_000))
            step = int(self.clock.step[0])
            if self.out_dir is not None:
                if step % snap_every == 0:
                    self._timed("snapshots", self.write_snapshot)
                if step % ckpt_every == 0:
                    self._timed("checkpoints", self.write_checkpoint)
            if progress and (t1 - last_report > 1.0 or step >= end_step):
                last_report = t1
                self._timed("progress", self._report, wall0, step0, end_step)
        if self.out_dir is not None:
            self._timed("checkpoints", self.write_checkpoint)
        if progress:
            sys.stderr.write("\n" + self.breakdown() + "\n")

    def advance_steps(self, n: int) -> None:
        """Take n steps without output (tests, benchmarks)."""
        self._advance_to(int(self.clock.step[0]) + n)

    def _advance_to(self, target: int) -> None:
        while True:
            t0 = time.perf_counter()
            status, bad = self.stepper.advance(self.ps, self.pairs, self.clock, self.prm, target)
            t1 = time.perf_counter()
            self.timers["forces+integration"] += t1 - t0
            if status == NEED_REBUILD:
                self._rebuild()
                self.timers["neighbour rebuild"] += time.perf_counter() - t1
            elif status == BAD_PARTICLE:
                raise SimulationError(self._bad_particle_message(bad))
            else:
                return

    def _timed(self, stage: str, fn, *args) -> None:
        t0 = time.perf_counter()
        fn(*args)
        self.timers[stage] += time.perf_counter() - t0

    def _report(self, wall0: float, step0: int, end_step: int) -> None:
        step = int(self.clock.step[0])
        elapsed = time.perf_counter() - wall0
        rate = (step - step0) / elapsed if elapsed > 0 else 0.0
        eta = (end_step - step) / rate if rate > 0 else math.inf
        sys.stderr.write(
            f"\rt = {self.time:9.3f} / {end_step * self.dt:.3f} s | {rate:9.0f} steps/s | "
            f"{rate * self.n_free / 1e6:6.2f} M particle-steps/s | ETA {eta:7.1f} s | "
            f"E_kin {self.kinetic_energy():.3e} J | max overlap {100 * self.max_overlap():.2f}% d ")
        sys.stderr.flush()

    def breakdown(self) -> str:
        total = sum(self.timers.values()) or 1.0
        rows = [f"  {k:<20s} {v:9.3f} s  {100 * v / total:5.1f} %" for k, v in self.timers.items()]
        steps = int(self.clock.step[0])
        return "\n".join([f"time per stage ({steps} steps, {self.n_rebuilds} neighbour builds):",
                          *rows])

    def _bad_particle_message(self, k: int) -> str:
        return (f"particle id {int(self.ps.gid[k])} became invalid at t = {self.time:.6f} s: "
                f"position ({self.ps.x[k, 0]:.6g}, {self.ps.x[k, 1]:.6g}) m, velocity "
                f"({self.ps.v[k, 0]:.6g}, {self.ps.v[k, 1]:.6g}) m/s (non-finite, or outside the "
                f"cell); the last checkpoint is kept")

    # -- measurements -------------------------------------------------------------------------
    def kinetic_energy(self) -> float:
        return float(diag.kinetic_energy(self.ps, int(self.clock.n_move[0])))

    def total_energy(self) -> float:
        """Kinetic + elastic energy (J): disk-disk springs and flat-ring springs."""
        e = self.kinetic_energy() + diag.elastic_energy(self.ps, self.pairs, self.prm)
        if self.options.walls:
            r_out = outer_radius(self.time, self.prm)[0]
            e += diag.ring_elastic_energy(self.ps, self.pairs, self.prm, r_out)
        return float(e)

    def max_overlap(self) -> float:
        """Largest overlap over the diameter of the smaller free particle in the contact."""
        r_out = outer_radius(self.time, self.prm)[0]
        return float(diag.max_overlap_ratio(self.ps, self.pairs, self.prm, r_out))

    def contacts(self) -> dict[str, np.ndarray]:
        e = self.scene.effects
        return diag.contact_table(self.ps, self.pairs, self.prm, self.friction, e.normal_damping)

    def particle_arrays(self) -> dict[str, np.ndarray]:
        """Current particle data sorted by id (the snapshot layout)."""
        ps, n = self.ps, int(self.clock.n_local[0])
        order = np.argsort(ps.gid[:n], kind="stable")
        c = self.contacts()["ids"]
        coord = np.bincount(np.searchsorted(ps.gid[:n][order], c.ravel()), minlength=n)
        return {"id": ps.gid[order], "kind": ps.kind[order], "position": ps.x[order],
                "velocity": ps.v[order], "omega": ps.omega[order], "theta": ps.theta[order],
                "radius": ps.radius[order], "mass": ps.mass[order], "force": ps.f[order],
                "torque": ps.tau[order], "coordination": coord}

    # -- output ---------------------------------------------------------------------------------
    def write_snapshot(self) -> None:
        every = max(1, int(round(self.scene.output.snapshot_interval / self.dt)))
        write_snapshot(self.out_dir, int(self.clock.step[0]) // every, self.time,
                       int(self.clock.step[0]), self.particle_arrays(),
                       self.contacts() if self.scene.output.contacts else None)

    def checkpoint_state(self) -> tuple[dict[str, np.ndarray], dict[str, object]]:
        ps, pairs, n = self.ps, self.pairs, int(self.clock.n_local[0])
        arrays = {k: getattr(ps, k)[:n] if getattr(ps, k).shape[0] else getattr(ps, k)
                  for k in ARRAYS}
        c = int(pairs.count[0])
        arrays["pair_lo"] = ps.gid[pairs.i[:c]]
        arrays["pair_hi"] = ps.gid[pairs.j[:c]]
        arrays["pair_xi"] = pairs.xi[:c] if self.friction else np.zeros((0, 2))
        attrs = {"step": int(self.clock.step[0]), "time": self.time, "dt": self.dt,
                 "ring_angle": self.prm.omega_in * self.time,
                 "fingerprint": self.scene.fingerprint(), "n_free": self.n_free}
        return arrays, attrs

    def write_checkpoint(self, path: str | Path | None = None) -> None:
        arrays, attrs = self.checkpoint_state()
        save_checkpoint(path or self.out_dir / "checkpoint.h5", arrays, attrs)

    def _restore(self, path: str | Path) -> None:
        arrays, attrs = load_checkpoint(path)
        if attrs["fingerprint"] != self.scene.fingerprint():
            raise SceneError(f"--restart {path}: the checkpoint belongs to a different scene "
                             "(geometry, particles, contact law, effects or dt differ)")
        if attrs["dt"] != self.dt:
            raise SceneError(f"--restart {path}: checkpoint dt = {attrs['dt']} s differs from "
                             f"the scene's dt = {self.dt} s")
        n = int(self.clock.n_local[0])
        if arrays["gid"].size != n:
            raise SceneError(f"--restart {path}: {arrays['gid'].size} particles in the "
                             f"checkpoint, {n} in the scene")
        for k in ARRAYS:
            getattr(self.ps, k)[: arrays[k].shape[0]] = arrays[k]
        self.clock.step[0] = int(attrs["step"])
        self._rebuild(old_keys=(arrays["pair_lo"], arrays["pair_hi"], arrays["pair_xi"]))

"""Benchmark: what each stage of the step costs per particle, alone and inside the step loop,
for states of different scenes or times, on one core.

    python run_scripts/benchmarks/bench_stages.py SCENE.toml CHECKPOINT.h5 [SCENE CHECKPOINT ...]
                                                  [--rounds 5] [--reps 100]

Each checkpoint is restored in one process. Per round and state: the force evaluation
(``forces.contact_forces``), the two half kicks, and the pass that fuses them with the drift
(``integrate.kick_drift``), each repeated inside one compiled loop (so that no Python call is
timed; about ``--reps`` x 3000 / N repetitions, on caches warm with that stage's own arrays;
the kicks with h = 0, the fused pass with zero forces and undone, so the state stays), then
steps of the real step loop (``Simulation.advance_steps``, its neighbour builds subtracted). Prints ns per particle, median (range) over the rounds; the first round
includes compiling the loops. Comparing the stages alone with the step tells what the loop
as a whole adds (each stage finding its arrays evicted by the others).
"""

from __future__ import annotations

import os
import statistics
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numba as nb  # noqa: E402
import numpy as np  # noqa: E402
from bench_order import parse_states  # noqa: E402

from pardem.core.forces import contact_forces, new_work  # noqa: E402
from pardem.core.integrate import PEAK_LANES, kick, kick_drift  # noqa: E402
from pardem.core.jit import JIT  # noqa: E402

LOOP = dict(JIT, cache=False)


@nb.njit(**LOOP)
def forces_loop(ps, pairs, n_all, prm, t, o, rotation, walls, work, reps):
    for _ in range(reps):
        contact_forces(ps, pairs, n_all, prm, t, 0.0, o, rotation, walls, work, False)


@nb.njit(**LOOP)
def kicks_loop(ps, n, prm, opts, reps):
    for _ in range(reps):
        kick(ps, n, 0.0, prm, opts, False)
        kick(ps, n, 0.0, prm, opts, True)


@nb.njit(**LOOP)
def drift_loop(ps, clock, prm, opts, peaks, reps):
    for _ in range(reps):
        kick_drift(ps, clock, prm, opts, peaks, True)


def round_times(sim, reps: int) -> dict[str, float]:
    """Seconds per particle of each stage alone and of a step, for one round."""
    ps, pairs, prm, opts, clock = sim.ps, sim.pairs, sim.prm, sim.options, sim.clock
    n, n_all = int(clock.n_owned[0]), int(clock.n_local[0])
    work, peaks = new_work(opts.contact, int(pairs.count[0])), np.empty((2, PEAK_LANES))
    out = {}
    t = time.perf_counter()
    forces_loop(ps, pairs, n_all, prm, sim.time, opts.contact, opts.rotation, opts.walls, work,
                reps)
    out["forces"] = (time.perf_counter() - t) / reps / n
    t = time.perf_counter()
    kicks_loop(ps, n, prm, opts, reps)
    out["two kicks"] = (time.perf_counter() - t) / reps / n
    x, theta, step = ps.x.copy(), ps.theta.copy(), int(clock.step[0])
    v, omega, f, tau = ps.v.copy(), ps.omega.copy(), ps.f.copy(), ps.tau.copy()
    ps.f[:], ps.tau[:] = 0.0, 0.0  # the kicks add zeros: the speeds stay bounded
    t = time.perf_counter()
    drift_loop(ps, clock, prm, opts, peaks, reps)
    out["kicks+drift"] = (time.perf_counter() - t) / reps / n
    ps.x[:], ps.theta[:], clock.step[0], clock.phase[0] = x, theta, step, 0
    ps.v[:], ps.omega[:], ps.f[:], ps.tau[:] = v, omega, f, tau
    steps = max(50, reps * 2)
    sim.reset_timers()
    t = time.perf_counter()
    sim.advance_steps(steps)
    out["step"] = (time.perf_counter() - t - sim.timers["neighbour rebuild"]) / steps / n
    return out


def main() -> None:
    from pardem.input.scene_file import load_scene
    from pardem.simulation import Simulation

    args, states = parse_states(__doc__, 5, "--reps", 100)
    sims = [Simulation(load_scene(s), restart=c) for s, c in states]
    times: list[dict] = [{} for _ in sims]
    for _ in range(args.rounds):
        for sim, got in zip(sims, times):
            reps = max(1, args.reps * 3000 // int(sim.clock.n_owned[0]))
            for stage, v in round_times(sim, reps).items():
                got.setdefault(stage, []).append(1e9 * v)
    for sim, got in zip(sims, times):
        n = int(sim.clock.n_owned[0])
        print(f"{sim.scene.info.name}, N = {n}, t = {sim.time:.3g} s, "
              f"{int(sim.pairs.count[0]) / n:.2f} listed pairs per particle: " + ", ".join(
                  f"{k} {statistics.median(v):.1f} ({min(v):.1f}-{max(v):.1f})"
                  for k, v in got.items()) + " ns per particle", flush=True)


if __name__ == "__main__":
    main()

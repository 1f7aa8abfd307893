"""Benchmark (an experiment for storage in spatial order): what the rows' order costs the step
on one core, at growing N.

    python run_scripts/benchmarks/bench_order.py SCENE.toml CHECKPOINT.h5 [SCENE CHECKPOINT ...]
                                                 [--rounds 7] [--steps 200] [--order morton|raster]

Per scene, two Simulations restart from the same checkpoint in one process: one keeps the
rows in gid order (the placement's raster order, mixed by the shear since), the other has its
free disks relabelled along a curve through their current positions (``--order``: a Morton
curve of cells one diameter wide, or the placement's raster of lattice rows; gid := rank on
the curve, then the lists rebuilt), so that storage, pair list and summation all follow space.
The relabelled run is a different labelling, so its bits differ: this measures what spatial
order could gain, not a pardem option. Rounds alternate the two: the force evaluation of the
current state (``forces.contact_forces``, one call), the opening kick and the drift, in ns per
particle (minima over the rounds), then ``--steps`` steps of each run (median; builds included,
and apart).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")


def spread_bits(v: np.ndarray) -> np.ndarray:
    """The bits of v (< 2^32) spread to the even positions (a Morton key's half)."""
    v = v & 0xFFFFFFFF
    for shift, mask in ((16, 0x0000FFFF0000FFFF), (8, 0x00FF00FF00FF00FF),
                        (4, 0x0F0F0F0F0F0F0F0F), (2, 0x3333333333333333),
                        (1, 0x5555555555555555)):
        v = (v | (v << shift)) & mask
    return v


def relabel(sim, curve: str) -> None:
    """Sort the owned rows along a curve through their current positions; gid := position.
    "morton": a Morton curve of cells one diameter wide. "raster": rows one lattice row
    (sqrt(3)/2 diameters) high, each by x: the order the placement gave the lattice, so this
    undoes what the shear has mixed since."""
    ps, n = sim.ps, int(sim.clock.n_owned[0])
    x = ps.x[:n]
    cell = 2.0 * float(ps.radius[:n].max())
    if curve == "morton":
        ij = np.floor((x - x.min(axis=0)) / cell).astype(np.int64)
        order = np.argsort(spread_bits(ij[:, 0]) | (spread_bits(ij[:, 1]) << 1), kind="stable")
    else:
        row = np.floor((x[:, 1] - x[:, 1].min()) / (0.5 * np.sqrt(3.0) * cell))
        order = np.lexsort((x[:, 0], row))
    for name in ps._fields:
        a = getattr(ps, name)
        if a.shape[0] >= n:
            a[:n] = a[:n][order]
    ps.gid[:n] = np.arange(n)
    sim.pairs.count[0] = 0  # the springs start afresh: the old gids no longer apply
    sim.rebuilder.rebuild(history=None, rebalance=False)


def stage_times(sim) -> dict[str, float]:
    from pardem.core.forces import contact_forces, new_work
    from pardem.core.integrate import PEAK_LANES, kick, kick_drift

    ps, pairs, prm, opts = sim.ps, sim.pairs, sim.prm, sim.options
    n = int(sim.clock.n_owned[0])
    n_all = int(sim.clock.n_local[0])
    work = new_work(opts.contact, int(pairs.count[0]))
    peaks = np.empty((2, PEAK_LANES))
    out = {}
    t = time.perf_counter()
    contact_forces(ps, pairs, n_all, prm, sim.time, 0.0, opts.contact, opts.rotation,
                   opts.walls, work, False)
    out["forces"] = (time.perf_counter() - t) / n
    t = time.perf_counter()
    kick(ps, n, 0.0, prm, opts, False)  # h = 0: the state stays
    out["kick"] = (time.perf_counter() - t) / n
    x, v, step = ps.x.copy(), ps.v.copy(), int(sim.clock.step[0])
    t = time.perf_counter()
    kick_drift(ps, sim.clock, prm, opts, peaks, False)
    out["kick+drift"] = (time.perf_counter() - t) / n
    ps.x[:], ps.v[:], sim.clock.step[0], sim.clock.phase[0] = x, v, step, 0
    return out


def parse_states(doc: str, rounds: int, option: str, default: int, orders: bool = False,
                 extra=None):
    """The command line of a benchmark over restored states (also bench_stages.py,
    bench_windows.py): SCENE CHECKPOINT pairs, ``--rounds``, one more integer option, with
    ``orders`` ``--order``, and whatever ``extra(parser)`` adds. Returns ``(args, [(scene,
    checkpoint), ...])``."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("pairs", nargs="+", help="SCENE.toml CHECKPOINT.h5, repeated")
    ap.add_argument("--rounds", type=int, default=rounds)
    ap.add_argument(option, type=int, default=default)
    if orders:
        ap.add_argument("--order", choices=["morton", "raster"], default="morton",
                        help="the curve the relabelled copy follows")
    if extra is not None:
        extra(ap)
    args = ap.parse_args()
    if len(args.pairs) % 2:
        ap.error("give a checkpoint after each scene")
    return args, list(zip(args.pairs[::2], args.pairs[1::2]))


def main() -> None:
    from pardem.input.scene_file import load_scene
    from pardem.simulation import Simulation

    args, states = parse_states(__doc__, 7, "--steps", 200, orders=True)
    for path, ckpt in states:
        scene = load_scene(path)
        sims = {"gid order": Simulation(scene, restart=ckpt),
                args.order: Simulation(scene, restart=ckpt)}
        relabel(sims[args.order], args.order)
        n = sims[args.order].n_free
        best: dict = {k: {} for k in sims}
        steps: dict = {k: [] for k in sims}
        for _ in range(args.rounds):
            for k, sim in sims.items():
                for stage, v in stage_times(sim).items():
                    best[k][stage] = min(best[k].get(stage, np.inf), v)
        builds: dict = {k: [] for k in sims}
        for _ in range(args.rounds):
            for k, sim in sims.items():
                sim.reset_timers()
                t = time.perf_counter()
                sim.advance_steps(args.steps)
                steps[k].append((time.perf_counter() - t) / args.steps / n)
                builds[k].append(sim.timers["neighbour rebuild"] / args.steps / n)
        for k, sim in sims.items():
            stages = ", ".join(f"{s} {1e9 * v:.1f}" for s, v in best[k].items())
            print(f"{scene.info.name}, N = {n}, {k}: {stages} ns per particle (minima); "
                  f"{args.steps} steps: {1e9 * statistics.median(steps[k]):.1f} ns per "
                  f"particle-step (median; {1e9 * min(steps[k]):.1f}-"
                  f"{1e9 * max(steps[k]):.1f}), of which builds "
                  f"{1e9 * statistics.median(builds[k]):.1f}; {int(sim.pairs.count[0])} pairs",
                  flush=True)


if __name__ == "__main__":
    main()

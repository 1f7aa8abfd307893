"""Benchmark: this machine's costs per owned disk and per ghost, one core per rank, for the
many-rank model of docs/scaling.md (``ghost_counts.py --costs``).

    python run_scripts/benchmarks/machine_costs.py SCENE CHECKPOINT [--rounds 5] [--steps 4000]
                                                   [--cuts sectors 2x1]

Every round runs, each a fresh ``mpiexec`` job restarted from CHECKPOINT: 1 rank, then 2 ranks
with each of the two ``--cuts``. Two sectors share only two radial edges, two rings the whole
circle between them: the same disks and work, ~4 times the ghosts (the refresh as messages in
both, as between nodes). Per run the step loop is
timed after two warm-up builds (the busiest rank's wall time, builds included). Prints per round
and then as medians (range over the rounds):
- c: ns per owned disk and step on 1 rank (everything a step does, builds included);
- c_g: ns per step that one more ghost costs a rank: (t_rings - t_sectors) / (G_rings -
  G_sectors) of the busier rank in the same round (the ghost's refresh, its pairs, its
  share of the builds);
- the 2-rank speed-up of each cut.
The per-message and Allreduce costs come from ``mpi_latency.py`` (2 ranks).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


def worker(scene: str, ckpt: str, cut: str, steps: int) -> None:
    """One timed run under mpiexec: prints a JSON line on rank 0."""
    from mpi4py import MPI

    import bench
    from pardem.simulation import Simulation

    comm = MPI.COMM_WORLD
    run = Simulation(bench.scene_of(Path(scene), False), restart=ckpt,
                     comm=comm if comm.size > 1 else None, cut=cut)
    builds = run.n_rebuilds
    while run.n_rebuilds < builds + 2:  # compiled code loaded, caches warm
        run.advance_steps(50)
    comm.Barrier()
    t0 = time.perf_counter()
    run.advance_steps(steps)
    comm.Barrier()
    wall = time.perf_counter() - t0
    ranks = comm.gather(run.stats(), root=0)
    if comm.rank == 0:
        print(json.dumps({"wall": wall, "n_free": run.n_free, "ranks": ranks}))


def timed(scene: Path, ckpt: Path, p: int, cut: str, steps: int) -> dict:
    # messages, as between nodes (B's 65 ghosts of sectors would go through shared memory)
    env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1",
               PARDEM_HALO="messages")
    out = subprocess.run([str(Path(sys.executable).parent / "mpiexec"), "-n", str(p),
                          sys.executable, "-m", "mpi4py", str(Path(__file__).resolve()),
                          str(scene), str(ckpt), "--worker", cut, "--steps",
                          str(steps)], check=True, capture_output=True, text=True, env=env,
                         timeout=3600)
    return json.loads(out.stdout.strip().splitlines()[-1])


def spread(values: list[float], digits: int = 2) -> str:
    return (f"{statistics.median(values):.{digits}f} ({min(values):.{digits}f}-"
            f"{max(values):.{digits}f})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("checkpoint", type=Path)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--cuts", nargs=2, default=["sectors", "2x1"])
    ap.add_argument("--worker", metavar="CUT", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker(str(args.scene), str(args.checkpoint), args.worker, args.steps)
    c, c_g, speedups = [], [], {cut: [] for cut in args.cuts}
    for k in range(args.rounds):
        one = timed(args.scene, args.checkpoint, 1, "sectors", args.steps)
        n = one["n_free"]
        c.append(1e9 * one["wall"] / (args.steps * n))
        runs = {cut: timed(args.scene, args.checkpoint, 2, cut, args.steps) for cut in args.cuts}
        t = {cut: 1e9 * r["wall"] / args.steps for cut, r in runs.items()}
        g = {cut: max(d["ghosts"] for d in r["ranks"]) for cut, r in runs.items()}
        pairs = {cut: max(d["pairs"] for d in r["ranks"]) for cut, r in runs.items()}
        a, b = args.cuts
        c_g.append((t[b] - t[a]) / (g[b] - g[a]))
        for cut in args.cuts:
            speedups[cut].append(one["wall"] / runs[cut]["wall"])
        print(f"round {k + 1}: {n} disks, 1 rank {c[-1]:.2f} ns per disk-step; 2 ranks: "
              + "; ".join(f"{cut} {t[cut] / 1e3:.1f} us per step, {g[cut]} ghosts, "
                          f"{pairs[cut]} pairs (busiest rank)" for cut in args.cuts)
              + f"; c_g = {c_g[-1]:.1f} ns per ghost-step", flush=True)
    print(f"{args.scene.stem} from {args.checkpoint.name}, {args.steps} steps, {args.rounds} "
          f"rounds: c = {spread(c)} ns per owned disk-step; c_g = {spread(c_g, 1)} ns per "
          "ghost-step; speed-up on 2 ranks "
          + ", ".join(f"{cut} {spread(v)}" for cut, v in speedups.items()))


if __name__ == "__main__":
    main()

"""Benchmark: what ``Simulation.run``'s loop (writers, progress, chunking, signal checks) costs
against bare ``advance_steps`` from the same checkpoint, on P ranks, alternated round by round
in one invocation.

    python run_scripts/benchmarks/run_overhead.py CHECKPOINT [--scene SCENE.toml] [--span 5]
        [--ranks 2] [--repeats 3]

Each round starts both modes from CHECKPOINT (``pardem run`` writes one every 10 s) and takes
``--span`` simulated seconds: ``run`` into a scratch folder with the scene's snapshots,
checkpoints and ring samples, ``advance_steps`` with no output. Prints steps/s, the
forces+integration and rebuild timers and the builds per round, then the medians.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def worker(mode: str, checkpoint: str, scene_path: str, span: float) -> None:
    from mpi4py import MPI

    from pardem.input.scene_file import load_scene
    from pardem.simulation import Simulation

    comm = MPI.COMM_WORLD
    with tempfile.TemporaryDirectory() as scratch:
        out = comm.bcast(scratch if comm.rank == 0 else None) if mode == "run" else None
        sim = Simulation(load_scene(scene_path), out_dir=out, restart=checkpoint, comm=comm,
                         overwrite=True)
        steps = int(round(span / sim.dt))
        comm.Barrier()
        t0 = time.perf_counter()
        if mode == "run":
            sim.run(end=sim.time + span, progress=False)
        else:
            sim.advance_steps(steps)
        comm.Barrier()
        wall = time.perf_counter() - t0
        comm.Barrier()  # every rank done with the scratch folder before rank 0 removes it
    if comm.rank == 0:
        t = sim.timers
        print(f"{mode} {steps} {wall:.4f} {t['forces+integration']:.4f} "
              f"{t['neighbour rebuild']:.4f} {sim.n_rebuilds}", flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkpoint")
    ap.add_argument("--scene", default=str(ROOT / "run_scripts" / "scenes" / "couette_B.toml"))
    ap.add_argument("--span", type=float, default=5.0, help="simulated seconds per round")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--worker", choices=("run", "advance"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        worker(a.worker, a.checkpoint, a.scene, a.span)
        return 0
    mpiexec = str(Path(sys.executable).parent / "mpiexec")
    rates = {"run": [], "advance": []}
    for r in range(a.repeats):
        for mode in rates:
            done = subprocess.run(
                [mpiexec, "-n", str(a.ranks), sys.executable, "-m", "mpi4py", __file__,
                 a.checkpoint, "--scene", a.scene, "--span", str(a.span), "--worker", mode],
                capture_output=True, text=True, check=True)
            _, steps, wall, forces, rebuild, builds = done.stdout.split()
            rates[mode].append(int(steps) / float(wall))
            print(f"round {r + 1} {mode:8s}: {int(steps)} steps in {float(wall):.2f} s = "
                  f"{rates[mode][-1]:,.0f} steps/s (forces+integration {float(forces):.2f} s, "
                  f"rebuild {float(rebuild):.2f} s, {builds} builds)", flush=True)
    run, bare = (statistics.median(rates[m]) for m in ("run", "advance"))
    print(f"median steps/s on {a.ranks} ranks: run {run:,.0f}, advance_steps {bare:,.0f}; "
          f"run / advance_steps = {run / bare:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

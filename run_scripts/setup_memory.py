"""Benchmark: a scene's set-up time and largest resident memory per rank, per owned disk.

    mpiexec -n P python run_scripts/setup_memory.py SCENE.toml [--steps 20]

Builds the scene on the ranks of COMM_WORLD (the placement, each rank's share, the first
exchange and neighbour build), runs ``--steps`` steps, and prints per rank the seconds of
``Simulation(scene)``, then the largest resident set size (``ru_maxrss``: the imports, the
compiled kernels and the peak of the set-up included) after the set-up and after the steps, in
MB and in bytes per owned disk. Run it once beforehand, so that the kernels come from numba's
cache (compiling takes memory of its own). To compare two versions of the code, run it with
``PYTHONPATH`` pointing to each (e.g. a ``git worktree`` of the older commit), alternately.
"""

from __future__ import annotations

import argparse
import resource
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--steps", type=int, default=20)
    args = ap.parse_args()
    from mpi4py import MPI

    from pardem.scene import load_scene
    from pardem.simulation import Simulation

    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    sim = Simulation(load_scene(args.scene), comm=comm if comm.size > 1 else None)
    took = time.perf_counter() - t0
    at_setup = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    sim.advance_steps(args.steps)
    at_end = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    n = int(sim.clock.n_owned[0])
    lines = comm.gather(f"rank {comm.rank}: {n} owned disks, set-up {took:.1f} s; largest RSS "
                        f"after the set-up {at_setup / 1e6:.0f} MB ({at_setup / n:.0f} B per "
                        f"owned disk), after {args.steps} steps {at_end / 1e6:.0f} MB "
                        f"({at_end / n:.0f} B)", root=0)
    if comm.rank == 0:
        print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()

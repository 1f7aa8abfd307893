"""Benchmark: a scene's set-up time and resident memory per rank, per owned disk, at the set-up
and while it steps.

    mpiexec -n P python run_scripts/benchmarks/setup_memory.py SCENE.toml [--steps 20]
                                                               [--restart CKPT]

Builds the scene on the ranks of COMM_WORLD (the placement, or the checkpoint ``--restart``;
each rank's share, the first exchange and neighbour build), runs ``--steps`` steps, and prints
per rank the seconds of ``Simulation(scene)``, the largest resident set size of the set-up
(``ru_maxrss``: the imports, the compiled kernels and the peak of the set-up included), the
resident set after it, and the largest one of the whole run (``ru_maxrss`` again), in MB and
in bytes per owned disk, with the stages that raised that peak during the steps (``build``: a
neighbour build, ``exchange``: one that also migrates and selects ghosts, ``steps``: the
compiled step loop), and the resident set after the steps. Peaks inside a compiled call last
milliseconds, so only the kernel's high-water mark sees them (a thread sampling ``VmRSS`` every
2 ms missed a 1M-disk run's exchange by 30 MB). Run it once beforehand, so that the kernels
come from numba's cache (compiling takes memory of its own). To compare two versions of the code,
run it with ``PYTHONPATH`` pointing to each (e.g. a ``git worktree`` of the older commit),
alternately.
"""

from __future__ import annotations

import argparse
import resource
import time


def resident(field: int = 1) -> int:
    """Resident bytes (``field`` 2: of them, mapped files and shared memory)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[field]) * resource.getpagesize()


def high_water() -> int:
    """The largest resident set so far (bytes)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--restart", help="checkpoint to start from")
    args = ap.parse_args()
    from mpi4py import MPI

    from pardem.input.scene_file import load_scene
    from pardem.simulation import Simulation

    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    sim = Simulation(load_scene(args.scene), comm=comm if comm.size > 1 else None,
                     restart=args.restart)
    took = time.perf_counter() - t0
    at_setup = high_water()
    after = resident()
    original = sim.rebuilder.rebuild

    peak_rises = {}

    def staged(*a, **k):
        before, exchanges = high_water(), sim.decomp.n_exchanges
        try:
            return original(*a, **k)
        finally:
            stage = "exchange" if sim.decomp.n_exchanges > exchanges else "build"
            peak_rises[stage] = peak_rises.get(stage, 0) + high_water() - before

    sim.rebuilder.rebuild = staged
    sim.advance_steps(args.steps)
    peak = high_water()
    peak_rises["steps"] = peak - at_setup - sum(peak_rises.values())
    n = int(sim.clock.n_owned[0])
    files = resident(2)
    private = peak - files
    rises = ", ".join(f"{k} +{v / 1e6:.0f} MB" for k, v in peak_rises.items() if v) or "none"
    lines = comm.gather(f"rank {comm.rank}: {n} owned disks, set-up {took:.1f} s; largest RSS "
                        f"of the set-up {at_setup / 1e6:.0f} MB ({at_setup / n:.0f} B per "
                        f"owned disk), RSS after it {after / 1e6:.0f} MB ({after / n:.0f} B); "
                        f"RSS after {args.steps} steps {resident() / 1e6:.0f} MB; largest of "
                        f"the run {peak / 1e6:.0f} MB ({peak / n:.0f} B; raised by: {rises}); "
                        f"{sim.n_rebuilds} builds, "
                        f"{sim.decomp.n_exchanges} exchanges, {int(sim.pairs.count[0])} pairs; "
                        f"mapped files {files / 1e6:.0f} MB, private at the peak "
                        f"{private / 1e6:.0f} MB ({private / n:.0f} B per owned disk)",
                        root=0)
    if comm.rank == 0:
        print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()

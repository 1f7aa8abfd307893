"""Output cost: wall time to write one particle snapshot (with contacts) of a paper-size cell.

    python run_scripts/benchmarks/bench_output.py [--scene run_scripts/scenes/couette_B.toml]
                                                  [--repeats 20]
    mpiexec -n 2 python -m mpi4py run_scripts/benchmarks/bench_output.py

Runs the scene through its compression (to --at seconds, default 2.5 s: dense, ~5000 contacts),
then times on rank 0, medians over --repeats calls:
- ``gather``: collecting particles, contacts and flat-ring contacts from all ranks to rank 0;
- ``write``: the snapshot file plus the regenerated XDMF indexes, for the first snapshots of a run
  and for snapshots number 230-240 (the index lists every earlier snapshot, so it grows);
- ``snapshot``: Simulation.write_snapshot as the run loop calls it (gather + write).
Prints one table; the numbers go into the issue notes.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

from pardem.output.snapshots import write_snapshot
from pardem.input.scene_file import load_scene
from pardem.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]


def timed(fn, repeats: int, comm) -> float:
    """Median wall time (ms) of fn() over repeats, every rank starting together."""
    times = []
    for _ in range(repeats):
        comm.Barrier()
        t0 = time.perf_counter()
        fn()
        comm.Barrier()
        times.append(1e3 * (time.perf_counter() - t0))
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(ROOT / "run_scripts" / "scenes" / "couette_B.toml"))
    ap.add_argument("--at", type=float, default=2.5, help="s of simulated time before timing")
    ap.add_argument("--repeats", type=int, default=20)
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    root = comm.rank == 0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = comm.bcast(tmp if root else None)
        sim = Simulation(load_scene(args.scene), out_dir=Path(tmp) / "run", comm=comm)
        sim.run(end=args.at, progress=False)
        sim.out_dir.mkdir(parents=True, exist_ok=True)

        def gather():
            return sim.particle_arrays(), sim.contacts(), sim.ring_contacts()

        t_gather = timed(gather, args.repeats, comm)
        t_snapshot = timed(sim.write_snapshot, args.repeats, comm)
        parts, contacts, ring = gather()
        rows = []
        if root:
            out = Path(tmp) / "series"
            out.mkdir()
            counter = iter(range(10_000))

            def write():
                write_snapshot(out, next(counter), sim.time, 0, parts, contacts, ring)

            first = timed(write, args.repeats, MPI.COMM_SELF)
            for _ in range(230 - args.repeats):
                write()
            late = timed(write, 10, MPI.COMM_SELF)
            size = sum(p.stat().st_size for p in (out / "snapshots").iterdir()) / next(counter)
            rows = [("particles", parts["id"].size), ("contacts", contacts["ids"].shape[0]),
                    ("ranks", comm.size), ("gather (ms)", f"{t_gather:.2f}"),
                    ("write, snapshots 1-20 (ms)", f"{first:.2f}"),
                    ("write, snapshots 230-240 (ms)", f"{late:.2f}"),
                    ("write_snapshot as in the run (ms)", f"{t_snapshot:.2f}"),
                    ("HDF5 bytes per snapshot", f"{size:.0f}")]
    if root:
        width = max(len(k) for k, _ in rows)
        for key, value in rows:
            print(f"{key:<{width}}  {value}")


if __name__ == "__main__":
    main()

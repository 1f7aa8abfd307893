"""How much of the time this machine takes away from a busy process, on every core at once.

    mpiexec -n 2 python -m mpi4py run_scripts/benchmarks/machine_noise.py [--seconds 5]

Each rank reads the clock (MPI_Wtime) in a compiled loop for the given time and adds up the
gaps of 5 us or more between two readings, by size. A shared VM that takes a core away for
tens of microseconds now and then slows a 2-rank job more than a serial one: every step waits
for the slower rank (docs/scaling.md, "The machine").
"""

import argparse

import numba as nb
import numpy as np
from mpi4py import MPI

from pardem.parallel.native import mpi_wtime

EDGES_US = (5.0, 20.0, 100.0, 1000.0, 10000.0)


@nb.njit
def gaps(seconds, edges):
    lost = np.zeros(edges.size)  # s lost in gaps of [edges[k], edges[k+1]) us (last: open)
    count = np.zeros(edges.size, np.int64)
    t0 = mpi_wtime()
    prev = t0
    while prev - t0 < seconds:
        t = mpi_wtime()
        d = (t - prev) * 1e6
        prev = t
        k = edges.size - 1
        while k >= 0 and d < edges[k]:
            k -= 1
        if k >= 0:
            lost[k] += d * 1e-6
            count[k] += 1
    return lost, count


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    seconds = ap.parse_args().seconds
    comm = MPI.COMM_WORLD
    edges = np.array(EDGES_US)
    gaps(0.01, edges)
    comm.Barrier()
    lost, count = gaps(seconds, edges)
    for rank, (lo, co) in enumerate(comm.gather((lost, count), root=0) or []):
        parts = ", ".join(
            f"{a:g}-{b:g} us: {c} ({100 * x / seconds:.3f} %)" if b else
            f">= {a:g} us: {c} ({100 * x / seconds:.3f} %)"
            for a, b, c, x in zip(EDGES_US, EDGES_US[1:] + (None,), co, lo))
        print(f"rank {rank}: {100 * lo.sum() / seconds:.2f} % of {seconds:g} s lost in gaps "
              f">= 5 us; {parts}")


if __name__ == "__main__":
    main()

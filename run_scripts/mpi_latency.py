"""Cost of the per-step MPI work on this machine, called from compiled code as the step loop
does: one neighbour exchange (Irecv + Isend + Waitall) of a given size, and one 3-value
MPI_Allreduce. Run on 2 ranks:

    mpiexec -n 2 python -m mpi4py run_scripts/mpi_latency.py

Prints the median over 5 repeats of 20,000 calls each (microseconds per call).
"""

import statistics
import time

import numba as nb
import numpy as np
from mpi4py import MPI

from pardem.mpi_native import mpi_allreduce, mpi_irecv, mpi_isend, mpi_waitall


@nb.njit
def exchange(n, comm, dbl, sb, rb, req, rsize, st, other):
    for _ in range(n):
        mpi_irecv(rb.ctypes.data, rb.size, dbl, other, 7, comm, req.ctypes.data)
        mpi_isend(sb.ctypes.data, sb.size, dbl, other, 7, comm, req.ctypes.data + rsize)
        mpi_waitall(2, req.ctypes.data, st.ctypes.data)


@nb.njit
def allreduce(n, comm, dbl, op, buf):
    for _ in range(n):
        mpi_allreduce(buf.ctypes.data, buf.ctypes.data + 24, 3, dbl, op, comm)


def main():
    comm = MPI.COMM_WORLD
    assert comm.size == 2, "run on 2 ranks"
    c, dbl, op = MPI._handleof(comm), MPI._handleof(MPI.DOUBLE), MPI._handleof(MPI.MAX)
    rsize = MPI._sizeof(MPI.Request)
    req = np.zeros(2 * rsize, np.uint8)
    st = np.zeros(2 * MPI._sizeof(MPI.Status), np.uint8)
    calls = 20_000

    def timed(fn, *args):
        fn(10, *args)
        xs = []
        for _ in range(5):
            comm.Barrier()
            t0 = time.perf_counter()
            fn(calls, *args)
            xs.append((time.perf_counter() - t0) / calls * 1e6)
        return statistics.median(xs)

    for ghosts in (0, 50, 300, 3000):
        n = 3 + 5 * ghosts
        us = timed(exchange, c, dbl, np.ones(n), np.zeros(n), req, rsize, st, 1 - comm.rank)
        if comm.rank == 0:
            print(f"exchange of {ghosts:5d} ghosts ({8 * n:6d} bytes each way): {us:6.2f} us")
    us = timed(allreduce, c, dbl, op, np.zeros(6))
    if comm.rank == 0:
        print(f"MPI_Allreduce of 3 doubles (max): {us:6.2f} us")


if __name__ == "__main__":
    main()

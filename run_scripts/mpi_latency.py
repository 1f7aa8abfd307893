"""Cost of the per-step MPI work on this machine, called from compiled code as the step loop
does: one neighbour exchange (Irecv + Isend + Waitall) of a given size, one 3-value
MPI_Allreduce, and the wait of an exchange of 50 ghosts with compute between the post and the
wait, with and without one MPI_Testall half way (does MPI move the message meanwhile?). Run on
2 ranks:

    mpiexec -n 2 python -m mpi4py run_scripts/mpi_latency.py

Prints the median over 5 repeats of 20,000 calls each (microseconds per call).
"""

import statistics
import time

import numba as nb
import numpy as np
from mpi4py import MPI

from pardem.mpi_native import (mpi_allreduce, mpi_irecv, mpi_isend, mpi_testall, mpi_waitall,
                               mpi_wtime)


@nb.njit
def exchange(n, comm, dbl, sb, rb, req, rsize, st, other):
    for _ in range(n):
        mpi_irecv(rb.ctypes.data, rb.size, dbl, other, 7, comm, req.ctypes.data)
        mpi_isend(sb.ctypes.data, sb.size, dbl, other, 7, comm, req.ctypes.data + rsize)
        mpi_waitall(2, req.ctypes.data, st.ctypes.data)


@nb.njit
def spin(us):
    t0 = mpi_wtime()
    while mpi_wtime() - t0 < us * 1e-6:
        pass


@nb.njit
def overlapped(n, comm, dbl, sb, rb, req, rsize, st, other, work_us, test):
    """Mean time (s) in MPI_Waitall after work_us of compute since the post."""
    flag = np.zeros(1, np.int32)
    waited = 0.0
    for _ in range(n):
        mpi_irecv(rb.ctypes.data, rb.size, dbl, other, 7, comm, req.ctypes.data)
        mpi_isend(sb.ctypes.data, sb.size, dbl, other, 7, comm, req.ctypes.data + rsize)
        spin(0.5 * work_us)
        if test:
            mpi_testall(2, req.ctypes.data, flag.ctypes.data, st.ctypes.data)
        spin(0.5 * work_us)
        t0 = mpi_wtime()
        mpi_waitall(2, req.ctypes.data, st.ctypes.data)
        waited += mpi_wtime() - t0
    return waited / n


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
    n = 3 + 5 * 50
    for work in (0.0, 5.0, 30.0):
        for test in (False, True):
            args = (c, dbl, np.ones(n), np.zeros(n), req, rsize, st, 1 - comm.rank, work, test)
            overlapped(10, *args)
            comm.Barrier()
            waits = [overlapped(5000, *args) for _ in range(3)]
            if comm.rank == 0:
                print(f"exchange of 50 ghosts, {work:4.0f} us of compute between post and wait"
                      f"{', MPI_Testall half way' if test else ''}: {1e6 * min(waits):5.2f} us "
                      "in MPI_Waitall")


if __name__ == "__main__":
    main()

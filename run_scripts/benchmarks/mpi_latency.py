"""Cost of the per-step MPI work on this machine, called from compiled code as the step loop
does: one neighbour exchange (Irecv + Isend + Waitall) of a given size, the same exchange
through the shared-memory window (write the block, publish the step, await the neighbour's,
read its block, as ``mpi_native.refresh_ghosts`` does), one 3-value MPI_Allreduce, and the
wait of an exchange of 50 ghosts with compute between the post and the wait, with and without
one MPI_Testall half way (does MPI move the message meanwhile?). Run on 2 ranks:

    mpiexec -n 2 python -m mpi4py run_scripts/benchmarks/mpi_latency.py

Prints the median over 5 repeats of 20,000 calls each (microseconds per call).
"""

import statistics
import time

import numba as nb
import numpy as np
from mpi4py import MPI
from numba.core import types

from pardem.parallel.halo import SEQ, SharedWindow
from pardem.parallel.native import (load_acquire, mpi_allreduce, mpi_irecv, mpi_isend,
                                    mpi_waitall, mpi_wtime, store_release)

# resolved in the libmpi that pardem.parallel.native loaded
mpi_testall = types.ExternalFunction("MPI_Testall", types.int32(types.int32, types.intp,
                                                                 types.intp, types.intp))


@nb.njit
def exchange(n, comm, dbl, sb, rb, req, rsize, st, other):
    for _ in range(n):
        mpi_irecv(rb.ctypes.data, rb.size, dbl, other, 7, comm, req.ctypes.data)
        mpi_isend(sb.ctypes.data, sb.size, dbl, other, 7, comm, req.ctypes.data + rsize)
        mpi_waitall(2, req.ctypes.data, st.ctypes.data)


@nb.njit
def shared_exchange(n, shared, seq, me, other, cap, size, step, sb, rb):
    """Like ``exchange`` through the window: sb written into this rank's row, rb read from the
    other's (step[0]: the last step published, carried over between calls)."""
    for _ in range(n):
        step[0] += 1
        base = SEQ + (step[0] & 1) * cap
        shared[me, base:base + size] = sb
        store_release(seq[me], 0, step[0])
        while load_acquire(seq[other], 0) < step[0]:
            pass
        rb[:] = shared[other, base:base + size]


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

    window = SharedWindow(comm, 3 + 5 * 3000)
    step = np.zeros(1, np.int64)
    for ghosts in (0, 50, 300, 3000):
        n = 3 + 5 * ghosts
        us = timed(exchange, c, dbl, np.ones(n), np.zeros(n), req, rsize, st, 1 - comm.rank)
        shm = timed(shared_exchange, window.shared, window.seq, comm.rank, 1 - comm.rank,
                    window.cap, n, step, np.ones(n), np.zeros(n))
        if comm.rank == 0:
            print(f"exchange of {ghosts:5d} ghosts ({8 * n:6d} bytes each way): {us:6.2f} us "
                  f"by messages, {shm:6.2f} us through shared memory")
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

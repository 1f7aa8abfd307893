"""MPI from compiled code: the per-step ghost refresh, called inside the step loop.

Stage: communication (one of the two MPI modules; the other, ``decomposition.py``, does the
rare collective work with mpi4py). At ~25 us per step, a return to Python for every exchange
would cost as much as the physics, so the step loop calls libmpi directly: the functions are
declared as external symbols (``numba.types.ExternalFunction``) and resolved in the libmpi that
mpi4py has already loaded. Unlike ctypes pointers, external symbols keep numba's on-disk cache
usable (the address is resolved when the cached code is loaded, not baked into it).

One message per neighbour rank per step, in each direction: a 3-value header (bad-particle flag,
largest displacement since the neighbour build, largest squared speed) followed by x, y,
v_pred x, v_pred y, w_pred of each ghost, in the order fixed at the last neighbour build. A
particle near both edges of a 2-rank cell is sent once, and the two edges share one ordered
stream, so edges cannot mix. If the neighbour sets do not cover all ranks (P > 3), the header
maxima are completed by one ``MPI_Allreduce``; otherwise the headers already hold the global
maxima and no collective is needed.

Handles: MPICH's are C ``int``; an MPI-ABI build uses pointers. Both are passed in registers on
x86-64 and AArch64, so the handle width is chosen from mpi4py's ``MPI._sizeof(MPI.Comm)``.
"""

from __future__ import annotations

from typing import NamedTuple

import llvmlite.binding as llvm
import numba as nb
import numpy as np
from mpi4py import MPI
from numba.core import types

from .jit import JIT

HEADER = 3  # bad flag, displacement, squared speed
GHOST_VALUES = 5  # x, y, v_pred x, v_pred y, w_pred
TAG = 4242


def _libmpi_path() -> str:
    """The libmpi mpi4py linked against (already mapped into this process)."""
    with open("/proc/self/maps") as maps:
        for line in maps:
            path = line.split()[-1]
            name = path.rsplit("/", 1)[-1]
            if name.startswith(("libmpi.so", "libmpi_abi.so", "libmpich.so")):
                return path
    raise RuntimeError("pardem: cannot find the MPI library that mpi4py loaded")


llvm.load_library_permanently(_libmpi_path())
_H = types.int32 if MPI._sizeof(MPI.Comm) == 4 else types.intp
_I, _P = types.int32, types.intp
mpi_irecv = types.ExternalFunction("MPI_Irecv", _I(_P, _I, _H, _I, _I, _H, _P))
mpi_isend = types.ExternalFunction("MPI_Isend", _I(_P, _I, _H, _I, _I, _H, _P))
mpi_waitall = types.ExternalFunction("MPI_Waitall", _I(_I, _P, _P))
mpi_testall = types.ExternalFunction("MPI_Testall", _I(_I, _P, _P, _P))  # run_scripts only
mpi_allreduce = types.ExternalFunction("MPI_Allreduce", _I(_P, _P, _I, _H, _H, _H))
mpi_wtime = types.ExternalFunction("MPI_Wtime", types.float64())
mpi_alltoall = types.ExternalFunction("MPI_Alltoall", _I(_P, _I, _H, _P, _I, _H, _H))
mpi_alltoallv = types.ExternalFunction("MPI_Alltoallv", _I(_P, _P, _P, _H, _P, _P, _P, _H, _H))


class Halo(NamedTuple):
    """Plan of the per-step ghost refresh, rebuilt with the neighbour list.

    nbr [k] int64: neighbour ranks. send_idx [s] int64: local indices of owned particles sent,
    neighbour by neighbour (``send_off`` [k+1] offsets). recv_off [k+1]: the ghosts received
    from each neighbour, as offsets from the first ghost slot. sbuf, rbuf: message buffers.
    req, status: MPI request and status storage (bytes). red [6]: Allreduce buffers.
    ints: active (0 on one rank: no MPI call at all), comm, MPI_DOUBLE, MPI_MAX handles,
    request size in bytes, use_allreduce.
    wait [1] (s): time spent in MPI_Waitall and MPI_Allreduce, accumulated over the run (the
    decomposition passes the same array to every new plan): the exchange latency plus the
    wait for slower neighbours.
    """

    nbr: np.ndarray
    send_idx: np.ndarray
    send_off: np.ndarray
    recv_off: np.ndarray
    sbuf: np.ndarray
    rbuf: np.ndarray
    req: np.ndarray
    status: np.ndarray
    red: np.ndarray
    ints: np.ndarray
    wait: np.ndarray


@nb.njit(**JIT)
def halo_buffers(nbr, send_idx, send_off, recv_off, req_size, status_size):
    """The plan (arrays as in Halo) followed by its message, request, status and Allreduce
    buffers: the first nine fields of a Halo."""
    k = nbr.size
    return (nbr, send_idx, send_off, recv_off,
            np.zeros(HEADER * k + GHOST_VALUES * send_idx.size),
            np.zeros(HEADER * k + GHOST_VALUES * recv_off[k]),
            np.zeros(max(2 * k * req_size, 8), np.uint8),
            np.zeros(max(2 * k * status_size, 8), np.uint8), np.zeros(6))


def make_halo(comm, buffers: tuple, use_allreduce: bool, wait: np.ndarray | None = None) -> Halo:
    """Halo from ``halo_buffers``; ``wait``: the accumulator to keep using (the run's total),
    or None for a new one."""
    active = comm is not None and comm.Get_size() > 1
    ints = np.array([int(active), MPI._handleof(comm) if active else 0,
                     MPI._handleof(MPI.DOUBLE), MPI._handleof(MPI.MAX),
                     MPI._sizeof(MPI.Request), int(use_allreduce)], np.int64)
    return Halo(*buffers, ints, np.zeros(1) if wait is None else wait)


def collective_handles(comm) -> np.ndarray:
    """[comm, MPI_DOUBLE, MPI_INT] handles for ``alltoallv``, then the sizes (bytes) of an
    MPI_Request and an MPI_Status for ``halo_buffers`` (int64)."""
    return np.array([MPI._handleof(comm), MPI._handleof(MPI.DOUBLE), MPI._handleof(MPI.INT),
                     MPI._sizeof(MPI.Request), MPI._sizeof(MPI.Status)], np.int64)


@nb.njit(**JIT)
def alltoallv(sbuf, send_off, handles):
    """Piece ``sbuf[send_off[r]:send_off[r + 1]]`` (float64) to each rank r -> ``(rbuf, recv_off,
    mpi_error)``: the piece from rank q is ``rbuf[recv_off[q]:recv_off[q + 1]]``. Collective:
    the counts in one MPI_Alltoall, the data in one MPI_Alltoallv."""
    size = send_off.size - 1
    comm, dbl, i32 = handles[0], handles[1], handles[2]
    s_n = np.empty(size, np.int32)
    s_at = np.empty(size, np.int32)
    for r in range(size):
        s_n[r] = send_off[r + 1] - send_off[r]
        s_at[r] = send_off[r]
    r_n = np.zeros(size, np.int32)
    err = mpi_alltoall(s_n.ctypes.data, 1, i32, r_n.ctypes.data, 1, i32, comm)
    recv_off = np.zeros(size + 1, np.int64)
    r_at = np.empty(size, np.int32)
    for q in range(size):
        r_at[q] = recv_off[q]
        recv_off[q + 1] = recv_off[q] + r_n[q]
    rbuf = np.empty(recv_off[size])
    err |= mpi_alltoallv(sbuf.ctypes.data, s_n.ctypes.data, s_at.ctypes.data, dbl,
                         rbuf.ctypes.data, r_n.ctypes.data, r_at.ctypes.data, dbl, comm)
    return rbuf, recv_off, err


def serial_halo() -> Halo:
    """One rank: no neighbours, no MPI call."""
    none, zero = np.zeros(0, np.int64), np.zeros(1, np.int64)
    return make_halo(None, halo_buffers(none, none, zero, zero, 8, 8), False)


@nb.njit(**JIT)
def refresh_ghosts(ps, halo, first_ghost, bad_here, disp_here, v2_here):
    """Send owned boundary particles' x, v_pred, w_pred to the neighbours, receive the ghosts into
    ps[first_ghost:], and combine the headers into global maxima. Returns
    ``(mpi_error, bad_anywhere, disp, v2)``; with one rank it returns the inputs."""
    if halo.ints[0] == 0:
        return 0, bad_here, disp_here, v2_here
    comm, dbl, op_max, rsize = halo.ints[1], halo.ints[2], halo.ints[3], halo.ints[4]
    k = halo.nbr.size
    err = 0
    req = halo.req.ctypes.data
    for q in range(k):
        r0 = HEADER * q + GHOST_VALUES * halo.recv_off[q]
        cnt = HEADER + GHOST_VALUES * (halo.recv_off[q + 1] - halo.recv_off[q])
        err |= mpi_irecv(halo.rbuf.ctypes.data + 8 * r0, cnt, dbl, halo.nbr[q], TAG, comm,
                         req + rsize * q)
    sb = halo.sbuf
    for q in range(k):
        s0 = HEADER * q + GHOST_VALUES * halo.send_off[q]
        sb[s0] = 1.0 if bad_here else 0.0
        sb[s0 + 1] = disp_here
        sb[s0 + 2] = v2_here
        p = s0 + HEADER
        for s in range(halo.send_off[q], halo.send_off[q + 1]):
            i = halo.send_idx[s]
            sb[p] = ps.x[i, 0]
            sb[p + 1] = ps.x[i, 1]
            sb[p + 2] = ps.v_pred[i, 0]
            sb[p + 3] = ps.v_pred[i, 1]
            sb[p + 4] = ps.w_pred[i]
            p += GHOST_VALUES
        cnt = p - s0
        err |= mpi_isend(sb.ctypes.data + 8 * s0, cnt, dbl, halo.nbr[q], TAG, comm,
                         req + rsize * (k + q))
    t0 = mpi_wtime()
    err |= mpi_waitall(2 * k, req, halo.status.ctypes.data)
    halo.wait[0] += mpi_wtime() - t0
    bad_f = 1.0 if bad_here else 0.0
    disp, v2 = disp_here, v2_here
    rb = halo.rbuf
    g = first_ghost
    for q in range(k):
        r0 = HEADER * q + GHOST_VALUES * halo.recv_off[q]
        bad_f = max(bad_f, rb[r0])
        disp = max(disp, rb[r0 + 1])
        v2 = max(v2, rb[r0 + 2])
        p = r0 + HEADER
        for _ in range(halo.recv_off[q], halo.recv_off[q + 1]):
            ps.x[g, 0] = rb[p]
            ps.x[g, 1] = rb[p + 1]
            ps.v_pred[g, 0] = rb[p + 2]
            ps.v_pred[g, 1] = rb[p + 3]
            ps.w_pred[g] = rb[p + 4]
            p += GHOST_VALUES
            g += 1
    if halo.ints[5]:
        red = halo.red
        red[0] = bad_f
        red[1] = disp
        red[2] = v2
        t0 = mpi_wtime()
        err |= mpi_allreduce(red.ctypes.data, red.ctypes.data + 24, 3, dbl, op_max, comm)
        halo.wait[0] += mpi_wtime() - t0
        bad_f, disp, v2 = red[3], red[4], red[5]
    return err, bad_f > 0.0, disp, v2

"""The per-step ghost refresh under MPI, called from inside the compiled step loop, and the
compiled collectives of an exchange.

Stage: communication. At ~25 us per step, a return to Python for every refresh would cost as
much as the physics, so the step loop calls libmpi directly (``native.py``).

One block per neighbour rank per step, in each direction: a 3-value header (bad-particle flag,
largest displacement since the neighbour build, largest squared speed) followed by x, y,
v_pred x, v_pred y, w_pred of each ghost, in the order fixed at the last exchange. A particle
near both edges of a 2-rank cell is sent once, and the two edges share one ordered stream, so
edges cannot mix. If the neighbour sets do not cover all ranks (possible from P = 4 on;
checked at every exchange), the header maxima are completed by one ``MPI_Allreduce``;
otherwise the headers already hold the global maxima and no collective is needed.

When all ranks share one node with a core each (the usual case for this code), small refreshes
do not travel as messages at all: each rank owns a slice of one MPI-3 shared-memory window,
writes its outgoing blocks there (same layout as a message buffer), publishes the step number
with a release store, and reads its neighbours' blocks once their step numbers arrive (acquire
loads). For 50 ghosts that took 0.6-1.7 us against 1.9-2.9 us for Irecv + Isend + Waitall,
whose shared-memory messages move only inside an MPI call; from a few hundred ghosts on,
messages are faster (``run_scripts/benchmarks/mpi_latency.py``), so the decomposition chooses by
size at each exchange. Two buffers, alternating with the step's parity, keep a fast rank from
overwriting blocks a neighbour is still reading: it cannot get two steps ahead, because every
step waits for the neighbours' step numbers. A wait longer than ~5 us yields the core at every
further look. ``PARDEM_HALO=messages`` forces messages.
"""

from __future__ import annotations

import os
from typing import NamedTuple

import numba as nb
import numpy as np
from mpi4py import MPI

from ..core.jit import JIT
from ..core.timing import PACK, UNPACK, lap, stamp
from .native import (load_acquire, mpi_allreduce, mpi_alltoall, mpi_alltoallv, mpi_irecv,
                     mpi_isend, mpi_waitall, mpi_wtime, sched_yield, store_release)
from .plan import Halo, HaloConfig, Handles

HEADER = 3  # bad flag, displacement, squared speed
GHOST_VALUES = 5  # x, y, v_pred x, v_pred y, w_pred
TAG = 4242
SPINS = 4000  # reads of a neighbour's step number (~5 us) before yielding the core each time
SEQ = 8  # doubles at the start of a rank's shared slice: its step number (int64), one line


def handles_of(comm) -> Handles:
    return Handles(MPI._handleof(comm), MPI._handleof(MPI.DOUBLE), MPI._handleof(MPI.INT),
                   MPI._sizeof(MPI.Request), MPI._sizeof(MPI.Status), comm.Get_size())


@nb.njit(**JIT)
def halo_buffers(plan, handles):
    """The plan (nbr, send_idx, send_off, recv_off; arrays as in Halo) followed by its message,
    request, status and Allreduce buffers: the first nine fields of a Halo."""
    nbr, send_idx, send_off, recv_off = plan
    k = nbr.size
    return (nbr, send_idx, send_off, recv_off,
            np.zeros(HEADER * k + GHOST_VALUES * send_idx.size),
            np.zeros(HEADER * k + GHOST_VALUES * recv_off[k]),
            np.zeros(max(2 * k * handles.request_size, 8), np.uint8),
            np.zeros(max(2 * k * handles.status_size, 8), np.uint8), np.zeros(6))


def make_halo(comm, buffers: tuple, use_allreduce: bool, wait: np.ndarray | None = None,
              window: SharedWindow | None = None, peer_at: np.ndarray | None = None) -> Halo:
    """Halo from ``halo_buffers``; ``wait``: the accumulator to keep using (the run's total),
    or None for a new one; ``window`` and ``peer_at`` (``peer_offsets``): refresh through
    shared memory, else by messages."""
    shared = window is not None
    cfg = HaloConfig(MPI._handleof(comm), MPI._handleof(MPI.DOUBLE), MPI._handleof(MPI.MAX),
                     MPI._sizeof(MPI.Request), int(use_allreduce), int(shared),
                     window.cap if shared else 0, comm.Get_rank())
    if not shared:
        window, peer_at = _NO_WINDOW, np.zeros(0, np.int64)
    return Halo(*buffers, window.shared, window.seq, peer_at, cfg,
                np.zeros(3) if wait is None else wait)


class SharedWindow:
    """An MPI-3 shared-memory window for the ghost refresh: per rank a row of SEQ + 2 cap
    doubles (step number, then two buffers). Collective to create and to free."""

    def __init__(self, comm, cap: int):
        size, rank = comm.Get_size(), comm.Get_rank()
        width = SEQ + 2 * cap
        self.cap = cap
        self.win = MPI.Win.Allocate_shared(size * width * 8 if rank == 0 else 0, 8, comm=comm)
        memory, _ = self.win.Shared_query(0)  # one block, all rows: allocated by rank 0
        self.shared = np.frombuffer(memory, np.float64).reshape(size, width)
        self.seq = np.frombuffer(memory, np.int64).reshape(size, width)
        self.seq[rank, 0] = -1  # no step published yet
        comm.Barrier()

    def free(self) -> None:
        """Collective; the arrays must not be used afterwards."""
        self.shared = self.seq = None
        self.win.Free()

    @staticmethod
    def usable(comm) -> bool:
        """Collective: do all ranks share one node with a core each (waiting ranks spin), and
        ``PARDEM_HALO`` is not "messages"? Oversubscribed, a spinning rank holds the core the
        awaited one needs: 3 ranks on 2 cores ran 8x slower than with messages."""
        node = comm.Split_type(MPI.COMM_TYPE_SHARED)
        one_node = node.Get_size() == comm.Get_size()
        node.Free()
        cores = comm.allreduce(len(os.sched_getaffinity(0)), op=MPI.MIN)
        return (one_node and comm.Get_size() <= cores
                and os.environ.get("PARDEM_HALO", "shared") != "messages")


class _Dummy(NamedTuple):
    shared: np.ndarray
    seq: np.ndarray


_NO_WINDOW = _Dummy(np.zeros((1, SEQ)), np.zeros((1, SEQ), np.int64))


@nb.njit(**JIT)
def peer_offsets(nbr, send_idx, send_off, handles):
    """Collective (shared-memory refresh): tell each neighbour where its block lies in this
    rank's buffer. Returns ``(peer_at, need, mpi_error)``: where each neighbour nbr[q] keeps
    this rank's block, and the largest buffer (doubles) any rank needs."""
    size = handles.size
    k = nbr.size
    out = np.full(2 * size, -1.0)
    into = np.empty(2 * size)
    for r in range(size):
        out[2 * r + 1] = HEADER * k + GHOST_VALUES * send_idx.size
    for q in range(k):
        out[2 * nbr[q]] = HEADER * q + GHOST_VALUES * send_off[q]
    err = mpi_alltoall(out.ctypes.data, 2, handles.double, into.ctypes.data, 2, handles.double,
                       handles.comm)
    peer_at = np.empty(k, np.int64)
    for q in range(k):
        peer_at[q] = int(into[2 * nbr[q]])
    need = 0
    for r in range(size):
        need = max(need, int(into[2 * r + 1]))
    return peer_at, need, err


@nb.njit(**JIT)
def alltoallv(sbuf, send_off, handles):
    """Piece ``sbuf[send_off[r]:send_off[r + 1]]`` (float64) to each rank r -> ``(rbuf, recv_off,
    mpi_error)``: the piece from rank q is ``rbuf[recv_off[q]:recv_off[q + 1]]``. Collective:
    the counts in one MPI_Alltoall, the data in one MPI_Alltoallv."""
    size = send_off.size - 1
    s_n = np.empty(size, np.int32)
    s_at = np.empty(size, np.int32)
    for r in range(size):
        s_n[r] = send_off[r + 1] - send_off[r]
        s_at[r] = send_off[r]
    r_n = np.zeros(size, np.int32)
    err = mpi_alltoall(s_n.ctypes.data, 1, handles.int32, r_n.ctypes.data, 1, handles.int32,
                       handles.comm)
    recv_off = np.zeros(size + 1, np.int64)
    r_at = np.empty(size, np.int32)
    for q in range(size):
        r_at[q] = recv_off[q]
        recv_off[q + 1] = recv_off[q] + r_n[q]
    rbuf = np.empty(recv_off[size])
    err |= mpi_alltoallv(sbuf.ctypes.data, s_n.ctypes.data, s_at.ctypes.data, handles.double,
                         rbuf.ctypes.data, r_n.ctypes.data, r_at.ctypes.data, handles.double,
                         handles.comm)
    return rbuf, recv_off, err


@nb.njit(**JIT)
def exchange_ghosts(ps, halo, first_ghost, bad_here, disp_here, v2_here, step, timing):
    """Send owned boundary particles' x, v_pred, w_pred to the neighbours, receive the ghosts into
    ps[first_ghost:], and combine the headers into global maxima (``step``: the step the ghosts
    move to). Returns ``(mpi_error, bad_anywhere, disp, v2)``. ``timing`` on: the packing and
    unpacking are added to halo.wait[PACK], halo.wait[UNPACK] (``core.timing``)."""
    cfg = halo.cfg
    shared = cfg.shared != 0
    k = halo.nbr.size
    err = 0
    req = halo.req.ctypes.data
    base = SEQ + (step & 1) * cfg.cap  # this step's buffer in the shared rows
    t = stamp(timing)
    if shared:
        out = halo.shared[cfg.rank]
        for q in range(k):
            _pack(ps, halo, q, out, base + HEADER * q + GHOST_VALUES * halo.send_off[q],
                  bad_here, disp_here, v2_here)
        store_release(halo.seq[cfg.rank], 0, step)
        lap(timing, halo.wait, PACK, t)
        t0 = mpi_wtime()
        spins = 0
        for q in range(k):
            while load_acquire(halo.seq[halo.nbr[q]], 0) < step:
                spins += 1
                if spins > SPINS:  # more ranks than cores? let the awaited one run
                    sched_yield()
        halo.wait[0] += mpi_wtime() - t0
    else:
        for q in range(k):
            r0 = HEADER * q + GHOST_VALUES * halo.recv_off[q]
            cnt = HEADER + GHOST_VALUES * (halo.recv_off[q + 1] - halo.recv_off[q])
            err |= mpi_irecv(halo.rbuf.ctypes.data + 8 * r0, cnt, cfg.double, halo.nbr[q], TAG,
                             cfg.comm, req + cfg.request_size * q)
        for q in range(k):
            s0 = HEADER * q + GHOST_VALUES * halo.send_off[q]
            cnt = _pack(ps, halo, q, halo.sbuf, s0, bad_here, disp_here, v2_here)
            err |= mpi_isend(halo.sbuf.ctypes.data + 8 * s0, cnt, cfg.double, halo.nbr[q], TAG,
                             cfg.comm, req + cfg.request_size * (k + q))
        lap(timing, halo.wait, PACK, t)
        t0 = mpi_wtime()
        err |= mpi_waitall(2 * k, req, halo.status.ctypes.data)
        halo.wait[0] += mpi_wtime() - t0
    t = stamp(timing)
    bad_f = 1.0 if bad_here else 0.0
    disp, v2 = disp_here, v2_here
    g = first_ghost
    for q in range(k):
        if shared:
            rb, p = halo.shared[halo.nbr[q]], base + halo.peer_at[q]
        else:
            rb, p = halo.rbuf, HEADER * q + GHOST_VALUES * halo.recv_off[q]
        bad_f = max(bad_f, rb[p])
        disp = max(disp, rb[p + 1])
        v2 = max(v2, rb[p + 2])
        p += HEADER
        for _ in range(halo.recv_off[q], halo.recv_off[q + 1]):
            ps.x[g, 0] = rb[p]
            ps.x[g, 1] = rb[p + 1]
            ps.v_pred[g, 0] = rb[p + 2]
            ps.v_pred[g, 1] = rb[p + 3]
            ps.w_pred[g] = rb[p + 4]
            p += GHOST_VALUES
            g += 1
    lap(timing, halo.wait, UNPACK, t)
    if cfg.allreduce:
        red = halo.red
        red[0] = bad_f
        red[1] = disp
        red[2] = v2
        t0 = mpi_wtime()
        err |= mpi_allreduce(red.ctypes.data, red.ctypes.data + 24, 3, cfg.double, cfg.op_max,
                             cfg.comm)
        halo.wait[0] += mpi_wtime() - t0
        bad_f, disp, v2 = red[3], red[4], red[5]
    return err, bad_f > 0.0, disp, v2


@nb.njit(**JIT)
def _pack(ps, halo, q, out, at, bad, disp, v2):
    """The block for neighbour q into out[at:]: header, then x, v_pred, w_pred of each particle
    of its send list. Returns the block's length."""
    out[at] = 1.0 if bad else 0.0
    out[at + 1] = disp
    out[at + 2] = v2
    p = at + HEADER
    for s in range(halo.send_off[q], halo.send_off[q + 1]):
        i = halo.send_idx[s]
        out[p] = ps.x[i, 0]
        out[p + 1] = ps.x[i, 1]
        out[p + 2] = ps.v_pred[i, 0]
        out[p + 3] = ps.v_pred[i, 1]
        out[p + 4] = ps.w_pred[i]
        p += GHOST_VALUES
    return p - at

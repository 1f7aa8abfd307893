"""The exchange under MPI (the neighbour builds that ``Decomposition.exchange_due``
selects): migration with contact history and ghost selection in one round, then the new layout
of the rows, the wall disks near the domain, and the per-step refresh plan.

Stage: neighbour rebuild (``comm.Decomposition.exchange`` calls ``exchange_rows``; the
collective itself is ``halo.alltoallv``). Done as ~80 numpy and mpi4py calls with the
interpreter's caches cold after the step loop, the glue of a build cost more than its work, so
an exchange build is four compiled calls (send, receive and lay out, the shared-memory
offsets, then the lists, which ``rebuild.Rebuilder`` builds) around one Alltoall + Alltoallv.
The other builds are one compiled call (the lists).

One round suffices because the sender knows where each of its particles goes: to rank r it
sends the particles r will own (migrants, with the springs of their listed pairs) and the
particles another rank will own that lie within ``ghost_width`` of domain r (ghosts). A
migrant that lies near the sender's own domain is kept there as a ghost without a message.
Every row carries its new owner; each rank stores its ghosts sorted by (owner, gid), and each
owner sends its per-step refreshes to r in gid order of the particles near domain r, the same
set and order, because sender and owner apply the same distance test to the same bits.

Message to one rank: [rows, springs, rows x (owner, packed row), springs x (lo, hi, history)],
the history with as many columns as the pair list's (contact.model.history_columns).
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from ..contact.history import SHIFT, live_history, merge_history
from ..core.jit import JIT, copy_values
from ..core.sorted_runs import merge_slots, run_order
from ..core.state import move_rows, pack_particles, unpack_particles
from .halo import alltoallv, halo_buffers, peer_offsets
from .cut import domain_geometry, edge_distance, near, owners


class ExchangePlan(NamedTuple):
    """What an exchange needs to know of the decomposition: ``radii`` and ``edges`` (the cut's,
    ``cut.Cut``), this ``rank``, ``ghost_width`` (m: particles this close to a domain are its
    ghosts), ``wall_margin`` (m: wall disks this close to the domain are moved by its rank),
    ``width`` (columns of a packed row) and ``x_col`` (its first position column), ``shared``
    (the refresh goes through shared memory)."""

    radii: np.ndarray
    edges: np.ndarray
    rank: int
    ghost_width: float
    wall_margin: float
    width: int
    x_col: int
    shared: bool


@nb.njit(**JIT)
def _destination(gid, mig_gid, mig_dest):
    """Rank a migrant goes to (mig_gid sorted), or -1 if gid does not migrate."""
    k = np.searchsorted(mig_gid, gid)
    return mig_dest[k] if k < mig_gid.size and mig_gid[k] == gid else -1


def exchange_rows(ps, pairs, clock, counts, plan, from_list, history, handles):
    """The whole exchange (collective): ``send_rows``, ``receive_rows``, with a shared-memory
    refresh ``halo.peer_offsets``, and the new counts in clock. ``counts``: (n_owned, n_local)
    before it (owned rows, owned rows + wall disks). ``history``: (lo, hi, rows), used unless
    ``from_list`` (the springs of the current pair list). Returns ``(mpi_error, received,
    peers)``: received as from receive_rows, peers (peer_at, need) or empty.

    Three compiled calls from Python, not one compiled call around them: numba optimises a
    kernel's code again with the code of every kernel it calls linked in, so a compiled
    wrapper would add ~4 s to the first run's compile for ~0.1 ms per exchange saved."""
    n_owned = counts[0]
    rbuf, recv_off, owner, history, err = send_rows(ps, pairs, n_owned, plan, from_list, history,
                                                    handles)
    received = receive_rows(ps, counts, owner, (rbuf, recv_off), plan, history, handles,
                            err == 0)
    written, _, n_own, n_near, _, _, _, ghosts, _, buffers = received
    history = None  # merged into the received springs: not kept (peak memory at 10^6)
    peer_at, need = np.zeros(0, np.int64), 0
    if plan.shared:
        peer_at, need, err2 = peer_offsets(buffers[0], buffers[1], buffers[2], handles)
        err |= err2
    clock.n_owned[0] = n_own
    clock.n_local[0] = n_own + counts[1] - n_owned
    clock.n_ghost[0] = ghosts.shape[0]
    if written:
        clock.n_moving[0] = n_own + n_near
    return err, received, (peer_at, need)


@nb.njit(**JIT)
def send_rows(ps, pairs, n_owned, plan, from_list, history, handles):
    """Migrate and ghost the owned rows ps[:n_owned]. History: the non-zero rows of the current
    pair list if ``from_list``, else ``history`` (lo, hi, rows; a restart's). Returns
    ``(rbuf, recv_off, owner, history, mpi_error)``: the messages received, each owned row's
    new owner, and the history sent from."""
    rank, ghost_width, width = plan.rank, plan.ghost_width, plan.width
    e = domain_geometry(plan.radii, plan.edges)
    size = e.shape[0]
    lo, hi, xi = history
    if from_list:
        lo, hi, xi = live_history(ps.gid, pairs.i, pairs.j, pairs.hist, pairs.count[0])
    owner = owners(ps.x[:n_owned], plan.radii, plan.edges, rank)
    # rows for each destination: its migrants and its ghosts owned by someone else
    dest = np.zeros((size, n_owned), np.bool_)
    n_rows = np.zeros(size, np.int64)
    for p in range(n_owned):
        px, py, o = ps.x[p, 0], ps.x[p, 1], owner[p]
        for r in range(size):
            if r != rank and (r == o or edge_distance(px, py, e, r) < ghost_width):
                dest[r, p] = True
                n_rows[r] += 1
    leaving = np.flatnonzero(owner != rank)
    order = run_order(ps.gid[leaving], leaving.size)  # owned rows are gid-sorted: one run
    mig_gid, mig_dest = ps.gid[leaving][order], owner[leaving][order]
    spring_lo = np.empty(lo.size, np.int64)  # destination of each spring's partners (-1: none)
    spring_hi = np.empty(lo.size, np.int64)
    n_springs = np.zeros(size, np.int64)
    for k in range(lo.size if leaving.size else 0):
        d_lo = _destination(lo[k], mig_gid, mig_dest)
        d_hi = _destination(hi[k], mig_gid, mig_dest)
        spring_lo[k] = d_lo
        spring_hi[k] = d_hi
        if d_lo >= 0:
            n_springs[d_lo] += 1
        if d_hi >= 0 and d_hi != d_lo:
            n_springs[d_hi] += 1
    send_off = np.zeros(size + 1, np.int64)
    hw = xi.shape[1]  # history columns
    for r in range(size):
        used = n_rows[r] + n_springs[r] > 0
        send_off[r + 1] = send_off[r] + (2 + n_rows[r] * (width + 1) + (2 + hw) * n_springs[r]
                                         if used else 0)
    sbuf = np.empty(send_off[size])
    for r in range(size):
        if send_off[r + 1] == send_off[r]:
            continue
        b = send_off[r]
        sbuf[b] = n_rows[r]
        sbuf[b + 1] = n_springs[r]
        idx = np.flatnonzero(dest[r, :n_owned])
        rows = np.empty((idx.size, width))
        pack_particles(ps, idx, rows)
        at = b + 2
        for q in range(idx.size):
            sbuf[at] = owner[idx[q]]
            copy_values(sbuf[at + 1:at + 1 + width], rows[q])
            at += width + 1
        for k in range(lo.size if leaving.size else 0):
            if spring_lo[k] == r or spring_hi[k] == r:
                sbuf[at] = lo[k]
                sbuf[at + 1] = hi[k]
                copy_values(sbuf[at + 2:at + 2 + hw], xi[k])
                at += 2 + hw
    rbuf, recv_off, err = alltoallv(sbuf, send_off, handles)
    return rbuf, recv_off, owner, (lo, hi, xi), err


@nb.njit(**JIT)
def receive_rows(ps, counts, owner, received, plan, history, handles, write):
    """Lay out [owned, gid-sorted | wall disks | ghosts, sorted by (owner, gid)] from the kept
    rows and the messages of ``send_rows`` (``received``: rbuf, recv_off), merge the migrants'
    history into ``history`` (lo, hi, rows), and plan the per-step refresh. ``counts`` as in
    exchange_rows. If ``write`` and ps is large enough, the rows are written (the owned ones
    moved in place, ``state.move_rows``; only the ghosts if no owned row left or arrived) and
    the wall disks arranged (``arrange_walls``). Returns ``(written, moved, n_own, n_near, n_arrived, own, walls, ghosts, history,
    halo)``: n_own the new number of owned rows, halo the ``halo_buffers`` of the refresh plan.
    If not written, the caller stores own and walls (if moved; else they are empty and
    ps[:n_local] stays) and ghosts; if written, own is empty."""
    n_owned, n_local = counts
    rbuf, recv_off = received
    rank, ghost_width, width = plan.rank, plan.ghost_width, plan.width
    lo, hi, xi = history
    e = domain_geometry(plan.radii, plan.edges)
    size = e.shape[0]
    n_arr, n_gh, n_sp = 0, 0, 0
    for q in range(size):
        if recv_off[q + 1] > recv_off[q]:
            b = recv_off[q]
            for k in range(int(rbuf[b])):
                if int(rbuf[b + 2 + k * (width + 1)]) == rank:
                    n_arr += 1
                else:
                    n_gh += 1
            n_sp += int(rbuf[b + 1])
    kept = np.flatnonzero(owner == rank)
    stay = np.zeros(n_owned, np.bool_)  # migrants kept here as ghosts
    for p in range(n_owned):
        near_here = edge_distance(ps.x[p, 0], ps.x[p, 1], e, rank) < ghost_width
        stay[p] = owner[p] != rank and near_here
    stay_idx = np.flatnonzero(stay)
    ghosts = np.empty((n_gh + stay_idx.size, width))
    key = np.empty(ghosts.shape[0], np.int64)
    pack_particles(ps, stay_idx, ghosts[n_gh:])
    arrivals = np.empty((n_arr, width))
    hw = xi.shape[1]  # history columns
    springs = np.empty((n_sp, 2 + hw))
    a, g, s = 0, 0, 0
    for q in range(size):
        if recv_off[q + 1] == recv_off[q]:
            continue
        b = recv_off[q]
        at = b + 2
        for k in range(int(rbuf[b])):
            if int(rbuf[at]) == rank:
                copy_values(arrivals[a], rbuf[at + 1:at + 1 + width])
                a += 1
            else:
                copy_values(ghosts[g], rbuf[at + 1:at + 1 + width])
                key[g] = (int(rbuf[at]) << SHIFT) | int(rbuf[at + 1])
                g += 1
            at += width + 1
        for k in range(int(rbuf[b + 1])):
            copy_values(springs[s], rbuf[at:at + 2 + hw])
            s += 1
            at += 2 + hw
    for k in range(stay_idx.size):
        key[n_gh + k] = (owner[stay_idx[k]] << SHIFT) | ps.gid[stay_idx[k]]
    ghosts = ghosts[run_order(key, key.size)]  # ascending runs: per sender, then the stayers

    moved = kept.size < n_owned or n_arr > 0
    n_own = kept.size + n_arr
    n_new = n_local - n_owned + n_own
    written = write and n_new + ghosts.shape[0] <= ps.gid.size
    own = np.empty((0, width))
    walls = np.empty((0, width))
    if moved:
        walls = np.empty((n_local - n_owned, width))
        pack_particles(ps, np.arange(n_owned, n_local), walls)
        # column 0: gid; each sender's arrivals are an ascending run
        arr_gid = arrivals[:, 0].astype(np.int64)
        arr_order = run_order(arr_gid, n_arr)
        at_kept, at_arr = merge_slots(ps.gid[kept], arr_gid, arr_order)
        if written:  # the kept rows stay in ps; only those after a migrant move
            move_rows(ps, kept, at_kept, arrivals, arr_order, at_arr)
        else:  # for the caller, who stores them in larger arrays
            rows = np.empty((kept.size, width))
            pack_particles(ps, kept, rows)
            own = np.empty((n_own, width))
            for k in range(kept.size):
                copy_values(own[at_kept[k]], rows[k])
            for r in range(n_arr):
                copy_values(own[at_arr[r]], arrivals[arr_order[r]])
    if n_sp:
        lo, hi, xi = merge_history(lo, hi, xi, springs)

    x_own = own[:, plan.x_col:plan.x_col + 2] if moved and not written else ps.x[:n_own]
    refresh = _refresh_plan(x_own, key, e, rank, ghost_width)

    n_near = 0
    if written:
        if moved:
            unpack_particles(walls, ps, n_own)
        unpack_particles(ghosts, ps, n_new)
        n_near = arrange_walls(ps, n_own, n_new, plan)
    return (written, moved, n_own, n_near, n_arr, own, walls, ghosts, (lo, hi, xi),
            halo_buffers(refresh, handles))


@nb.njit(**JIT)
def _refresh_plan(x_own, ghost_key, e, rank, ghost_width):
    """The per-step refresh plan: to each other rank, the owned particles (positions x_own, in
    storage order) near its domain; from it, the ghosts it owns (ghost_key: owner, gid). Returns
    ``(nbr, send_idx, send_off, recv_off)`` as in ``halo.Halo``."""
    size = e.shape[0]
    send = np.zeros((size, x_own.shape[0]), np.bool_)
    n_send = np.zeros(size, np.int64)
    for p in range(x_own.shape[0]):
        for r in range(size):
            if r != rank and edge_distance(x_own[p, 0], x_own[p, 1], e, r) < ghost_width:
                send[r, p] = True
                n_send[r] += 1
    n_recv = np.zeros(size, np.int64)
    for k in range(ghost_key.size):
        n_recv[ghost_key[k] >> SHIFT] += 1
    nbr = np.flatnonzero((n_send > 0) | (n_recv > 0))
    send_off = np.zeros(nbr.size + 1, np.int64)
    recv_off = np.zeros(nbr.size + 1, np.int64)
    for q in range(nbr.size):
        send_off[q + 1] = send_off[q] + n_send[nbr[q]]
        recv_off[q + 1] = recv_off[q] + n_recv[nbr[q]]
    send_idx = np.empty(send_off[nbr.size], np.int64)
    k = 0
    for q in range(nbr.size):  # element by element: see jit.copy_values
        for p in range(x_own.shape[0]):
            if send[nbr[q], p]:
                send_idx[k] = p
                k += 1
    return nbr, send_idx, send_off, recv_off


@nb.njit(**JIT)
def arrange_walls(ps, first, end, plan):
    """At an exchange: store the wall disks ps[first:end] (every one placed at the current
    time) that are within ``plan.wall_margin`` (m) of this rank's domain or inside it first.
    Returns how many that is. One compiled call: at an exchange, every call from Python that
    passes the particle arrays costs tens of us."""
    close = near(ps.x[first:end], plan.radii, plan.edges, plan.rank, plan.wall_margin)
    n_near = int(close.sum())
    if not close[:n_near].all():  # not yet stored near-first
        order = np.concatenate((np.flatnonzero(close), np.flatnonzero(~close))) + first
        rows = np.empty((order.size, plan.width))
        pack_particles(ps, order, rows)
        unpack_particles(rows, ps, first)
    return n_near

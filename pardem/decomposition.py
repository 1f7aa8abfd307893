"""Sector decomposition under MPI: migration with contact history, ghost selection, balancing,
and the gathers and reductions of output and diagnostics (mpi4py).

Stage: communication at neighbour-list builds and output times; the per-step ghost refresh is
compiled into the step loop (``mpi_native.py``). These are the only two modules that talk MPI.

At a neighbour build, every rank (collectively):
1. re-cuts the sectors if the particle counts drifted apart by more than ``balance_threshold``
   (cuts placed on a global angular histogram, identical on every rank);
2. sends each owned particle that left its sector to the new owner, with the tangential springs
   of all its listed pairs (keyed by the partners' gids; the new owner merges them with its own);
3. sends to every other rank the owned particles within ``ghost_width`` of that rank's sector:
   ghost_width = largest free diameter + skin covers every pair the Verlet list can hold;
4. fixes the per-step refresh plan (``mpi_native.Halo``): the same particles in the same order.
Wall disks are prescribed (a function of time only), so every rank moves all of them itself.
On one rank all of this is skipped: nothing to migrate, no ghosts, no messages.
"""

from __future__ import annotations

import math

import numpy as np
from mpi4py import MPI

from . import sectors as sec
from .mpi_native import Halo, make_halo, serial_halo
from .scene import SceneError
from .state import join_rows, packed, row_columns, row_width

History = tuple[np.ndarray, np.ndarray, np.ndarray]  # (gid_lo, gid_hi, xi [m,2]) sorted by key
HIST_BINS = 4096
REBALANCE_EVERY = 8  # neighbour builds between balance checks (counts drift slowly)


class Decomposition:
    """Ownership and communication of one run. ``comm``: an mpi4py communicator or None."""

    def __init__(self, comm, ghost_width: float, inner_radius: float = 0.0,
                 balance_threshold: float = 0.1):
        self.comm = comm if comm is not None and comm.Get_size() > 1 else None
        self.size = comm.Get_size() if comm is not None else 1
        self.rank = comm.Get_rank() if comm is not None else 0
        self.ghost_width = ghost_width
        self.inner_radius = inner_radius
        self.balance_threshold = balance_threshold
        self.sectors = sec.single()
        self.halo: Halo = serial_halo()
        self.n_migrated = 0  # particles received from other ranks (cumulative)
        self.n_rebalanced = 0
        self._builds = 0
        if self.size > 1 and inner_radius > 0.0:
            arc = 2.0 * math.pi * inner_radius / self.size
            if arc < ghost_width:
                raise SceneError(
                    f"{self.size} MPI ranks are too many for this cell: a sector would be "
                    f"{arc * 1e3:.2f} mm wide at the inner ring, narrower than the ghost width "
                    f"{ghost_width * 1e3:.2f} mm (largest diameter + skin); use at most "
                    f"{int(2.0 * math.pi * inner_radius / ghost_width)} ranks")

    @property
    def parallel(self) -> bool:
        return self.comm is not None

    # -- collectives (identity on one rank) ------------------------------------------------
    def max(self, value: float) -> float:
        return self.comm.allreduce(value, op=MPI.MAX) if self.comm else value

    def sum(self, value: float) -> float:
        return self.comm.allreduce(value, op=MPI.SUM) if self.comm else value

    def bcast(self, obj):
        """Rank 0's value of obj on every rank."""
        return self.comm.bcast(obj, root=0) if self.comm else obj

    def bcast_call(self, fn, *args):
        """Run fn on rank 0 and give every rank its result, or raise its exception everywhere."""
        if not self.comm:
            return fn(*args)
        result = None
        if self.rank == 0:
            try:
                result = (True, fn(*args))
            except Exception as e:  # re-raised on every rank below
                result = (False, e)
        ok, value = self.comm.bcast(result, root=0)
        if not ok:
            raise value
        return value

    def first_message(self, message: str | None) -> str | None:
        """The first non-None message over the ranks (every rank gets it)."""
        if not self.comm:
            return message
        return next((m for m in self.comm.allgather(message) if m is not None), None)

    def gather_rows(self, rows: dict[str, np.ndarray], key: str = "gid"):
        """Rows of every rank joined and sorted by ``key`` on rank 0 (None elsewhere)."""
        if not self.comm:
            parts = [rows]
        else:
            parts = self.comm.gather(rows, root=0)
            if self.rank != 0:
                return None
        joined = join_rows([p for p in parts if p[next(iter(p))].shape[0]] or parts[:1])
        k = joined[key]
        order = np.lexsort(k.T[::-1]) if k.ndim == 2 else np.argsort(k, kind="stable")
        return {name: v[order] for name, v in joined.items()}

    # -- sectors ---------------------------------------------------------------------------
    def place_sectors(self, x_free: np.ndarray) -> None:
        """Cut the annulus for the free particles x_free [N,2] (known to every rank)."""
        hist = sec.angle_histogram(x_free, HIST_BINS)
        self.sectors = sec.balanced(hist, self.size)

    def rebalance(self, x_owned: np.ndarray) -> None:
        """Re-cut the sectors if the owned counts differ by more than the threshold."""
        self._builds += 1
        if not self.comm or self._builds % REBALANCE_EVERY:
            return
        counts = np.array(self.comm.allgather(x_owned.shape[0]))
        if sec.imbalance(counts) <= self.balance_threshold:
            return
        hist = sec.angle_histogram(x_owned, HIST_BINS)
        self.comm.Allreduce(MPI.IN_PLACE, hist, op=MPI.SUM)
        self.sectors = sec.balanced(hist, self.size)
        self.n_rebalanced += 1

    # -- neighbour build -------------------------------------------------------------------
    def distribute(self, ps, n_move: int, friction: bool, history: History | None):
        """Migrate owned particles (the first n_move rows of ps) that left the sector, with
        their springs, and exchange ghosts. Returns ``(own, ghosts, history)``: the owned rows
        sorted by gid as a packed matrix (``state.packed``), or None if no particle left or
        arrived (then ps[:n_move] is still right), the ghost rows (packed), and the merged
        spring history; sets ``self.halo`` for the ghosts' per-step refresh.

        Rows travel and are rearranged as packed float64 matrices, one ``Alltoallv`` per
        round: at a build the interpreter's caches are cold and every numpy call costs
        several us, so one call per matrix instead of one per particle array matters."""
        comm, rank, size = self.comm, self.rank, self.size
        cols = row_columns(friction)
        width = row_width(friction)
        gid_col, x_cols = cols["gid"].start, cols["x"]
        owner = self.sectors.owner(ps.x[:n_move], rank)
        mine = owner == rank
        outgoing: list = [None] * size
        for r in np.unique(owner[~mine]):
            idx = np.flatnonzero(owner == r)
            springs = np.zeros((0, 4))
            if history is not None:
                gids = ps.gid[idx]
                h = np.isin(history[0], gids) | np.isin(history[1], gids)
                springs = np.column_stack([history[0][h], history[1][h], history[2][h]])
            outgoing[r] = np.concatenate([[idx.size, springs.shape[0]],
                                          packed(ps, idx, friction).ravel(), springs.ravel()])
        arrivals = [_unpack_migrants(buf, width) for buf in self._alltoall(outgoing)
                    if buf is not None]
        own = None
        if arrivals or not mine.all():
            own = np.concatenate([packed(ps, np.flatnonzero(mine), friction)]
                                 + [a[0] for a in arrivals])
            own = own[np.argsort(own[:, gid_col], kind="stable")]
            self.n_migrated += sum(a[0].shape[0] for a in arrivals)
            if history is not None:
                history = merge_history([history] + [a[1] for a in arrivals])
        x_own = ps.x[:n_move] if own is None else own[:, x_cols]

        send_idx: dict[int, np.ndarray] = {}
        outgoing = [None] * size
        for r in range(size):
            if r == rank:
                continue
            idx = np.flatnonzero(self.sectors.distance(x_own, r) < self.ghost_width)
            if idx.size:
                send_idx[r] = idx
                outgoing[r] = (packed(ps, idx, friction) if own is None else own[idx]).ravel()
        recv = {r: buf.reshape(-1, width) for r, buf in enumerate(self._alltoall(outgoing))
                if buf is not None}
        nbr = sorted(set(send_idx) | set(recv))
        empty = np.zeros(0, np.int64)
        send_list = [send_idx.get(r, empty) for r in nbr]
        recv_counts = [recv[r].shape[0] if r in recv else 0 for r in nbr]
        ghosts = (np.concatenate([recv[r] for r in nbr if r in recv]) if recv
                  else np.zeros((0, width)))
        # Header maxima are global only if every rank talks to every other one. On 2 ranks
        # both know: each is the other's neighbour or neither is.
        use_allreduce = len(nbr) < size - 1
        if size > 2:
            use_allreduce = comm.allreduce(use_allreduce, op=MPI.LOR)
        self.halo = make_halo(
            comm, nbr, np.concatenate(send_list) if send_list else empty,
            np.concatenate([[0], np.cumsum([s.size for s in send_list])]),
            np.concatenate([[0], np.cumsum(recv_counts)]), use_allreduce, self.halo.wait)
        return own, ghosts, history

    def _alltoall(self, outgoing: list) -> list:
        """One float64 buffer to each rank (None: nothing) -> the buffer from each (None:
        nothing): the counts in one ``Alltoall``, the data in one ``Alltoallv``."""
        send_n = np.array([0 if b is None else b.size for b in outgoing], np.int64)
        recv_n = np.zeros(self.size, np.int64)
        self.comm.Alltoall([send_n, MPI.INT64_T], [recv_n, MPI.INT64_T])
        send_at = np.concatenate([[0], np.cumsum(send_n)[:-1]])
        recv_at = np.concatenate([[0], np.cumsum(recv_n)[:-1]])
        parts = [b for b in outgoing if b is not None]
        sbuf = np.concatenate(parts) if parts else np.zeros(0)
        rbuf = np.empty(int(recv_n.sum()))
        self.comm.Alltoallv([sbuf, (send_n, send_at), MPI.DOUBLE],
                            [rbuf, (recv_n, recv_at), MPI.DOUBLE])
        return [rbuf[recv_at[r]:recv_at[r] + recv_n[r]] if recv_n[r] else None
                for r in range(self.size)]

    def ghost_values(self, own_values: np.ndarray) -> np.ndarray:
        """Values of an owned per-particle array for this rank's ghosts, in ghost order (output
        times only: the step loop refreshes just positions and predicted velocities)."""
        if not self.comm:
            return own_values[:0]
        h = self.halo
        outgoing: list = [None] * self.size
        for q, r in enumerate(h.nbr):
            outgoing[int(r)] = own_values[h.send_idx[h.send_off[q]:h.send_off[q + 1]]]
        incoming = self.comm.alltoall(outgoing)
        parts = [incoming[int(r)] for r in h.nbr if incoming[int(r)] is not None]
        return np.concatenate(parts) if parts else own_values[:0]

    def describe(self) -> str:
        if not self.comm:
            return "1 rank"
        deg = np.degrees(np.diff(self.sectors.edges))
        return (f"{self.size} ranks, sectors {', '.join(f'{d:.1f}' for d in deg)} deg, "
                f"ghost width {self.ghost_width * 1e3:.2f} mm")


def _unpack_migrants(buf: np.ndarray, width: int):
    """A migration message -> (packed rows, springs): [n, m, n rows of ``width``, m springs
    (lo, hi, xi_x, xi_y)]."""
    n, m = int(buf[0]), int(buf[1])
    rows = buf[2:2 + n * width].reshape(n, width)
    sp = buf[2 + n * width:].reshape(m, 4)
    return rows, (sp[:, 0].astype(np.int64), sp[:, 1].astype(np.int64), sp[:, 2:].copy())


def merge_history(parts: list[History]) -> History:
    """Springs from several sources joined, sorted by (lo, hi), duplicates dropped (a pair seen by
    two ranks has the same spring on both: same inputs, same arithmetic)."""
    lo = np.concatenate([p[0] for p in parts])
    hi = np.concatenate([p[1] for p in parts])
    xi = np.concatenate([p[2] for p in parts])
    order = np.lexsort((hi, lo))
    lo, hi, xi = lo[order], hi[order], xi[order]
    keep = np.ones(lo.size, bool)
    keep[1:] = (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
    return lo[keep], hi[keep], xi[keep]

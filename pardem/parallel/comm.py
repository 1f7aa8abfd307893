"""Decomposition of the annulus under MPI (sectors, or rings of sectors: ``cut.py``): migration
with contact history, ghost selection, balancing, and the gathers and reductions of output,
diagnostics and averaging (mpi4py).

Stage: communication at exchanges (the neighbour builds that migrate particles and select
ghosts) and at output times; the per-step ghost refresh is compiled into the step loop
(``halo.py``). One rank uses ``serial.SerialDecomposition`` instead, with the same interface
and no MPI.

Most neighbour builds only rebuild each rank's lists: the ghosts are selected with a margin
(``GHOST_MARGIN_SKINS``) and stay valid until the bodies have moved half of it
(``exchange_due``). At a build that needs an exchange, every rank (collectively):
1. re-cuts the domains if the particle counts drifted apart by more than ``balance_threshold``
   (cuts placed on global radial and angular histograms, identical on every rank, the number of
   rings kept; checked at every ``REBALANCE_EVERY``-th exchange);
2. in one compiled round (``exchange.py``) sends each owned particle that left its domain to
   the new owner, with the tangential springs of all its listed pairs (keyed by the partners'
   gids; the new owner merges them with its own), and to every other rank the particles it
   will need as ghosts: those within ``ghost_width`` of its domain (largest free diameter +
   skin, which covers every pair the Verlet list can hold, + the margin);
3. fixes the per-step refresh plan (``halo.Halo``): the same particles in the same order.
Wall disks are prescribed (a function of time only): every rank holds all of them; the step loop
moves the ones near its domain, and ``rebuild.Rebuilder`` places the others before an exchange
(which stores the near ones first) and before output.
"""

from __future__ import annotations

import math

import numpy as np
from mpi4py import MPI

from ..contact.history import NO_HISTORY
from ..core.state import ROW_ROOM, new_particles, packed, row_columns, row_width, unpack_particles
from . import cut as ct
from .choice import choose, cut_for
from .comm_rows import sorted_rows
from .exchange import ExchangePlan, arrange_walls, exchange_rows
from .halo import (GHOST_VALUES, HEADER, Halo, SharedWindow, halo_buffers, handles_of,
                   make_halo)
from .serial import History

REBALANCE_EVERY = 2  # exchanges between balance checks (counts drift slowly)
# Largest ghost refresh (doubles any rank sends per step, to all its neighbours together) that goes
# through shared memory: above ~200 ghosts, messages (a single copy by MPICH) were faster here
# (run_scripts/benchmarks/mpi_latency.py); below, shared memory saves the ~1.4 us message latency.
SHARED_HALO_LIMIT = HEADER + GHOST_VALUES * 200


class Decomposition:
    """Ownership and communication of one run on the ranks of ``comm`` (an mpi4py
    communicator of more than one rank)."""

    parallel = True

    def __init__(self, comm, reach_width: float, inner_radius: float = 0.0,
                 balance_threshold: float = 0.1, margin: float = 0.0, cut: str = "auto"):
        self.comm = comm
        self.size = comm.Get_size()
        self.rank = comm.Get_rank()
        # reach_width: largest free diameter + skin, the farthest a listed partner can be
        self.margin = margin
        self.reach_width = reach_width
        self.inner_radius = inner_radius
        self.ghost_width = reach_width + margin
        self.requested_cut = cut  # "auto", "sectors" or "RxA" (choice.requested_rings)
        self.r_top = 0.0  # m: the radial histogram's range, fixed at the first cut
        self.x_exchanged = np.zeros((0, 2))  # owned and wall rows at the last exchange (m)
        self.n_exchanges = 0
        self.balance_threshold = balance_threshold
        self.cut = ct.single()
        self.halo: Halo | None = None  # the refresh plan, made at the first exchange
        self.wait = np.zeros(3)  # s waiting, packing, unpacking (Halo.wait), the run's sums
        self._one = np.zeros(1)  # max's buffer
        self.n_migrated = 0  # particles received from other ranks (cumulative)
        self.n_rebalanced = 0
        self._balance_calls = 0
        self.handles = handles_of(comm)
        # the per-step ghost refresh goes through shared memory if all ranks are on one node
        self.shared_halo = SharedWindow.usable(comm)
        self.window: SharedWindow | None = None  # made (or grown) at an exchange, to its size
        self.n_windows = 0
        self.n_shared_exchanges = 0  # exchanges after which the refresh used shared memory

    # -- collectives -----------------------------------------------------------------------
    def max(self, value: float) -> float:
        """The largest value over the ranks, as a float (every build asks it, and every
        compiled call: a buffer Allreduce, ~4 us on 2 ranks here, not a pickled one, ~14)."""
        self._one[0] = value
        self.comm.Allreduce(MPI.IN_PLACE, self._one, op=MPI.MAX)
        return float(self._one[0])

    def sum(self, value):
        """Sum over the ranks of a number or (element-wise) of a float64 array."""
        if isinstance(value, np.ndarray):
            total = np.empty_like(value)
            self.comm.Allreduce(np.ascontiguousarray(value), total, op=MPI.SUM)
            return total
        return self.comm.allreduce(value, op=MPI.SUM)

    def bcast(self, obj):
        """Rank 0's value of obj on every rank."""
        return self.comm.bcast(obj, root=0)

    def bcast_call(self, fn, *args):
        """Run fn on rank 0 and give every rank its result, or raise its exception everywhere."""
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
        return next((m for m in self.comm.allgather(message) if m is not None), None)

    def join(self, rows: np.ndarray) -> np.ndarray:
        """Every rank's rows [m_k, ...] stacked in rank order, on every rank."""
        return np.concatenate(self.comm.allgather(rows))

    def gather_rows(self, rows: dict[str, np.ndarray], key: str = "gid"):
        """Rows of every rank joined and sorted by ``key`` on rank 0 (None elsewhere)."""
        parts = self.comm.gather(rows, root=0)
        if self.rank != 0:
            return None
        return sorted_rows([p for p in parts if p[next(iter(p))].shape[0]] or parts[:1], key)

    # -- the cut ---------------------------------------------------------------------------
    def place_cut(self, x_free: np.ndarray) -> None:
        """Cut the annulus for the free particles x_free [N,2] (known to every rank): the
        requested cut, or the one with the fewest ghosts (``choice.choose``)."""
        self.cut, self.r_top = choose(x_free, self.size, self.requested_cut, self.inner_radius,
                                      self.reach_width, self.ghost_width)

    def rebalance(self, x_owned: np.ndarray) -> None:
        """Re-cut the domains if the owned counts differ by more than the threshold (checked
        at every REBALANCE_EVERY-th exchange), with as many rings as before."""
        self._balance_calls += 1
        if self._balance_calls % REBALANCE_EVERY:
            return
        counts = np.array(self.comm.allgather(x_owned.shape[0]))
        if ct.imbalance(counts) <= self.balance_threshold:
            return
        self.cut = cut_for(x_owned, self.size, self.cut.rings, self.r_top, self._summed,
                           previous=self.cut)
        self.n_rebalanced += 1

    def _summed(self, hist: np.ndarray) -> np.ndarray:
        """An integer histogram summed over the ranks (in place)."""
        self.comm.Allreduce(MPI.IN_PLACE, hist, op=MPI.SUM)
        return hist

    # -- neighbour build -------------------------------------------------------------------
    def exchange_due(self, x_local: np.ndarray) -> bool:
        """Call once per neighbour build (collective), with the positions of the owned
        particles and the wall disks (every wall disk placed at the current time): whether
        particles must migrate and ghosts be selected again, or whether this rank may only
        rebuild its lists.

        Why that is safe: the ghosts were selected ``margin`` wider than the reach of a listed
        pair, and every owned particle lay in its domain, so while no body has moved more than
        margin/2 since then, every partner of an owned particle within the reach is still here
        (its distance to the domain then is at most reach + 2 x margin/2), and the wall disks
        the step loop moves still cover the domain (``exchange``). The test takes each
        body's own displacement since the exchange (the rows keep their order until the next
        one), the largest over all ranks, so every rank gets the same answer. The sum of each
        build's largest displacement bounds it too, but grows by about skin/2 per build
        however little the bodies moved: a disk rattling in its cage triggers builds, not
        exchanges."""
        if x_local.shape != self.x_exchanged.shape:  # no exchange yet
            moved = math.inf
        else:
            moved = ct.largest_move(x_local, self.x_exchanged)
        return self.max(moved) > 0.5 * self.margin

    def exchange(self, ps, pairs, clock, hist: int, history: History | None,
                 wall_margin: float):
        """Migrate owned particles that left the domain, with their contact history, and
        exchange ghosts, in one round (``exchange.exchange_rows``; it sets the counts in
        clock), then lay the rows out as [owned | wall disks, those within ``wall_margin`` (m)
        of the domain first | ghosts], in ps if they fit, else in larger arrays; sets
        ``self.halo`` for the ghosts' per-step refresh. Every wall disk must be at the current
        time: the layout sorts them by where they are, and they are where the next
        ``exchange_due`` measures from. History: ``history`` if given (a restart), else the
        non-zero rows of ``pairs`` (``hist`` columns, 0: none). Returns ``(ps, history)``: the
        arrays that hold the rows, and the history with the migrants' merged in (None
        without history columns)."""
        arguments = self.exchange_arguments(ps, pairs, clock, hist, history, wall_margin)
        err, (written, moved, _, _, n_arrived, own, walls, ghosts, springs, buffers), \
            (peer_at, need) = exchange_rows(*arguments)
        if err:
            raise RuntimeError(f"MPI exchange of migrants and ghosts failed on rank {self.rank}")
        self.n_migrated += n_arrived
        self.n_exchanges += 1
        # every rank knows need: all take the same branches
        shared = self.shared_halo and need <= SHARED_HALO_LIMIT
        self.n_shared_exchanges += shared
        if shared and (self.window is None or need > self.window.cap):
            if self.window is not None:
                self.window.free()
            self.window = SharedWindow(self.comm, need + need // 2 + 64)
            self.n_windows += 1
        # Header maxima are global only if every rank talks to every other one. On 2 ranks
        # both know: each is the other's neighbour or neither is.
        use_allreduce = buffers[0].size < self.size - 1
        if self.size > 2:
            use_allreduce = self.comm.allreduce(use_allreduce, op=MPI.LOR)
        self.halo = make_halo(self.comm, buffers, use_allreduce, self.wait,
                              self.window if shared else None, peer_at)
        n_owned, n_local = int(clock.n_owned[0]), int(clock.n_local[0])
        if not written:  # ps too small: store the rows in larger arrays
            rows = np.concatenate([own, walls, ghosts] if moved else
                                  [packed(ps, np.arange(n_local), hist), ghosts])
            ps = new_particles(int(ROW_ROOM * rows.shape[0]), hist)
            unpack_particles(rows, ps, 0)
            clock.n_moving[0] = n_owned + arrange_walls(ps, n_owned, n_local, arguments[4])
        self.x_exchanged = ps.x[:n_local].copy()
        return ps, (springs if hist else None)

    def exchange_arguments(self, ps, pairs, clock, hist, history, wall_margin) -> tuple:
        """The arguments of ``exchange.exchange_rows`` for ``exchange``'s (also what
        ``compile_ahead`` compiles it for)."""
        plan = ExchangePlan(self.cut.radii, self.cut.edges, self.rank, self.ghost_width,
                            wall_margin, row_width(hist), row_columns(hist)["x"].start,
                            self.shared_halo)
        counts = (int(clock.n_owned[0]), int(clock.n_local[0]))
        return (ps, pairs, clock, counts, plan, hist > 0 and history is None,
                history if history is not None else NO_HISTORY, self.handles)

    def empty_halo(self) -> Halo:
        """A refresh plan with no ghosts, of the same numba types as the real ones (what
        ``compile_ahead`` compiles the step loop for before the first exchange)."""
        none = np.zeros(0, np.int64)
        start = np.zeros(1, np.int64)
        return make_halo(self.comm, halo_buffers((none, none, start, start), self.handles),
                         False)

    def ghost_values(self, own_values: np.ndarray) -> np.ndarray:
        """Values of an owned per-particle array for this rank's ghosts, in ghost order (output
        times only: the step loop refreshes just positions and predicted velocities)."""
        h = self.halo
        outgoing: list = [None] * self.size
        for q, r in enumerate(h.nbr):
            outgoing[int(r)] = own_values[h.send_idx[h.send_off[q]:h.send_off[q + 1]]]
        incoming = self.comm.alltoall(outgoing)
        parts = [incoming[int(r)] for r in h.nbr if incoming[int(r)] is not None]
        return np.concatenate(parts) if parts else own_values[:0]

    def describe(self) -> str:
        return (f"{self.size} ranks, {self.cut.describe()}, "
                f"ghost width {self.ghost_width * 1e3:.2f} mm")


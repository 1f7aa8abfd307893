"""Sector decomposition under MPI: migration with contact history, ghost selection, balancing,
and the gathers and reductions of output and diagnostics (mpi4py).

Stage: communication at exchanges (the neighbour builds that migrate particles and select
ghosts) and at output times; the per-step ghost refresh is compiled into the step loop
(``mpi_native.py``). These are the only two modules that talk MPI.

Most neighbour builds only rebuild each rank's lists: the ghosts are selected with a margin
(``GHOST_MARGIN_SKINS``) and stay valid until the bodies have moved half of it
(``exchange_due``). At a build that needs an exchange, every rank (collectively):
1. re-cuts the sectors if the particle counts drifted apart by more than ``balance_threshold``
   (cuts placed on a global angular histogram, identical on every rank; checked at every
   ``REBALANCE_EVERY``-th exchange);
2. in one compiled round (``migration.py``) sends each owned particle that left its sector to
   the new owner, with the tangential springs of all its listed pairs (keyed by the partners'
   gids; the new owner merges them with its own), and to every other rank the particles it
   will need as ghosts: those within ``ghost_width`` of its sector (largest free diameter +
   skin, which covers every pair the Verlet list can hold, + the margin);
3. fixes the per-step refresh plan (``mpi_native.Halo``): the same particles in the same order.
Wall disks are prescribed (a function of time only): every rank holds all of them and places them
itself, the ones near its sector at every step, the others at exchanges and before output.
On one rank all of this is skipped: nothing to migrate, no ghosts, no messages.
"""

from __future__ import annotations

import math

import numpy as np
from mpi4py import MPI

from . import sectors as sec
from .migration import exchange_rows
from .mpi_native import (GHOST_VALUES, HEADER, Halo, SharedWindow, collective_handles,
                         make_halo, serial_halo)
from .scene import SceneError
from .state import NO_SPRINGS, join_rows, row_columns, row_width

History = tuple[np.ndarray, np.ndarray, np.ndarray]  # (gid_lo, gid_hi, xi [m,2]) sorted by key
HIST_BINS = 4096
REBALANCE_EVERY = 2  # exchanges between balance checks (counts drift slowly)
# Ghosts are selected this many skins wider than an interaction needs, so that most builds
# keep the ghosts and owners and only rebuild the lists locally (see exchange_due).
GHOST_MARGIN_SKINS = 4.0
# Largest ghost refresh (doubles any rank sends per step, to all its neighbours together) that goes
# through shared memory: above ~200 ghosts, messages (a single copy by MPICH) were faster here
# (run_scripts/mpi_latency.py); below, shared memory saves the ~1.4 us message latency.
SHARED_HALO_LIMIT = HEADER + GHOST_VALUES * 200


class Decomposition:
    """Ownership and communication of one run. ``comm``: an mpi4py communicator or None."""

    def __init__(self, comm, reach_width: float, inner_radius: float = 0.0,
                 balance_threshold: float = 0.1, margin: float = 0.0):
        self.comm = comm if comm is not None and comm.Get_size() > 1 else None
        self.size = comm.Get_size() if comm is not None else 1
        self.rank = comm.Get_rank() if comm is not None else 0
        # reach_width: largest free diameter + skin, the farthest a listed partner can be
        self.margin = margin
        self.ghost_width = reach_width + margin
        self.drift = 0.0  # bound on any body's displacement since the last exchange (m)
        self.n_exchanges = 0
        self.balance_threshold = balance_threshold
        self.sectors = sec.single()
        self.halo: Halo = serial_halo()
        self.n_migrated = 0  # particles received from other ranks (cumulative)
        self.n_rebalanced = 0
        self._balance_calls = 0
        self._handles = collective_handles(comm) if self.comm else None
        # the per-step ghost refresh goes through shared memory if all ranks are on one node
        self.shared_halo = SharedWindow.usable(comm) if self.comm else False
        self.window: SharedWindow | None = None  # made (or grown) at an exchange, to its size
        self.n_windows = 0
        self.n_shared_exchanges = 0  # exchanges after which the refresh used shared memory
        if self.size > 1 and inner_radius > 0.0:
            arc = 2.0 * math.pi * inner_radius / self.size
            if arc < reach_width:
                raise SceneError(
                    f"{self.size} MPI ranks are too many for this cell: a sector would be "
                    f"{arc * 1e3:.2f} mm wide at the inner ring, narrower than the interaction "
                    f"reach {reach_width * 1e3:.2f} mm (largest diameter + skin); use at most "
                    f"{int(2.0 * math.pi * inner_radius / reach_width)} ranks")

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
        """Re-cut the sectors if the owned counts differ by more than the threshold (checked
        at every REBALANCE_EVERY-th exchange)."""
        self._balance_calls += 1
        if not self.comm or self._balance_calls % REBALANCE_EVERY:
            return
        counts = np.array(self.comm.allgather(x_owned.shape[0]))
        if sec.imbalance(counts) <= self.balance_threshold:
            return
        hist = sec.angle_histogram(x_owned, HIST_BINS)
        self.comm.Allreduce(MPI.IN_PLACE, hist, op=MPI.SUM)
        self.sectors = sec.balanced(hist, self.size)
        self.n_rebalanced += 1

    # -- neighbour build -------------------------------------------------------------------
    def exchange_due(self, disp: float) -> bool:
        """Call once per neighbour build, with the largest displacement since the last build
        (global): it adds ``disp`` to the motion since the last exchange (``drift``, reset by
        ``distribute``) and answers whether particles must migrate and ghosts be selected again,
        or whether this rank may only rebuild its lists.

        Why that is safe: the ghosts were selected ``margin`` wider than the reach of a listed
        pair, and every owned particle lay in the sector, so while no body has moved more than
        margin/2 since then, every partner of an owned particle within the reach is still here
        (its distance to the sector then is at most reach + 2 x margin/2). The sum of the
        builds' largest displacements bounds that motion. Every rank gets the same answer
        (``disp`` is global). One rank: never."""
        if not self.comm:
            return False
        self.drift += disp
        return self.drift > 0.5 * self.margin

    def distribute(self, ps, pairs, clock, n_move: int, n_local: int, idle: int,
                   hist: int, ring_walls: bool, history: History | None, t: float, prm,
                   wall_margin: float):
        """Migrate owned particles (ps[:n_move]) that left the sector, with their springs, and
        exchange ghosts, in one round (``migration.exchange_rows``; it sets the counts in
        clock); sets ``self.halo`` for the ghosts' per-step refresh. Springs: ``history`` if
        given (a restart), else the non-zero ones of ``pairs``. If ps is large enough, the new
        rows are stored in it, the wall disks (the ``idle`` last ones placed at time t, s)
        arranged near-first, those within ``wall_margin`` (m) of the sector counted as near, and
        the lists built (pair list, and the ring-contact candidates if ``ring_walls``; springs
        only with a tangential history, ``hist`` columns of it (state.history_width); ``prm``:
        the step loop's Params). Returns ``(written, moved, own,
        walls, ghosts, lists, history)``: lists as from exchange_rows, the rest as from
        ``receive_rows``."""
        friction = hist > 0
        lo, hi, xi = history if history is not None else NO_SPRINGS
        err, (written, moved, n_near, n_arrived, own, walls, ghosts, springs, buffers), \
            (peer_at, need), lists = exchange_rows(
                ps, pairs, clock, n_move, n_local, idle, self.sectors.edges, self.rank,
                self.ghost_width, row_width(hist), row_columns(hist)["x"].start,
                friction and history is None, lo, hi, xi, t, prm, wall_margin, self._handles,
                self.shared_halo, friction, ring_walls)
        if err:
            raise RuntimeError(f"MPI exchange of migrants and ghosts failed on rank {self.rank}")
        self.n_migrated += n_arrived
        self.n_exchanges += 1
        self.drift = 0.0
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
        self.halo = make_halo(self.comm, buffers, use_allreduce, self.halo.wait,
                              self.window if shared else None, peer_at)
        return written, moved, own, walls, ghosts, lists, (springs if friction else None)

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

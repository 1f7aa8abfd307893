"""The neighbour build, owned by one object on one rank and under MPI alike: ``Rebuilder``.

Stage: neighbour rebuild, between compiled chunks of the step loop: when it returns
NEED_REBUILD, at start-up and after a state edit. The order is LAMMPS's (``Verlet::run`` at a
step where ``neighbor->decide()`` asks for a build; ``Verlet::setup`` the same without the
decision):

1. pre-exchange (``modify->pre_exchange()``; LAMMPS's ``fix balance`` re-cuts the domains
   there too): every wall disk the step loop did not move is placed at the current time, so
   that all bodies are where the time says (``place_idle_walls``); under MPI the domains are
   re-cut if the counts drifted apart (``Decomposition.rebalance``).
2. exchange and borders (``comm->exchange()``, ``comm->borders()``): under MPI, if the
   bodies moved far enough (``Decomposition.exchange_due``; always at set-up and after an
   edit: ``forced``), migrants and ghosts go in one round and the rows are laid out anew
   (``Decomposition.exchange``). One rank has nothing to exchange.
3. pre-neighbour (``modify->pre_neighbor()``): the wall skin of the coming interval
   (``neighbors.next_wall_skin``), the same on every rank.
4. neighbour build (``neighbor->build()``): the pair list with the contact history carried
   over by gid keys and the ring-contact candidates (``neighbors.build_lists``), grown and
   built again while they overflow.

Each step is done here and only here: the exchange neither places wall disks nor builds
lists, so an exchange build is the exchange's three compiled calls and one build.
"""

from __future__ import annotations

import time

from ..contact.history import NO_HISTORY
from .integrate import wall_travel
from .memory import unmapped
from .neighbors import build_lists, next_wall_skin
from .state import new_pairs
from ..boundaries.walls import place_wall_disks


class Rebuilder:
    """The neighbour builds of one Simulation (``sim``): it reads the state's arrays and
    replaces ``sim.ps`` (rows that no longer fit), ``sim.pairs`` (lists that overflow) and
    ``sim.prm`` (the wall skin), as LAMMPS's Verlet reaches the atoms, comm and neighbor
    classes of its instance."""

    def __init__(self, sim):
        self.sim = sim
        self.exchange_seconds = 0.0  # s in Decomposition.exchange (part of the builds' time)

    def rebuild(self, history=None, rebalance: bool = True, forced: bool = True) -> None:
        """New neighbour lists, in the order of the module docstring. ``forced``: under MPI,
        exchange whatever the bodies moved (set-up, a state edit); else only if
        ``Decomposition.exchange_due`` (the builds the step loop asks for). The history is
        carried over by gid keys, from ``history`` if given (a restart), else from the
        current list."""
        sim = self.sim
        decomp = sim.decomp
        self.place_idle_walls()
        if decomp.parallel and (forced or decomp.exchange_due(
                sim.ps.x[:int(sim.clock.n_local[0])])):
            with unmapped():  # its blocks fit no build's (memory.py)
                if rebalance:
                    decomp.rebalance(sim.ps.x[:int(sim.clock.n_owned[0])])
                t0 = time.perf_counter()
                sim.ps, history = decomp.exchange(sim.ps, sim.pairs, sim.clock, sim.hist,
                                                  history, sim.wall_margin)
                self.exchange_seconds += time.perf_counter() - t0
        if sim.prm.wall_disks:  # every rank builds at the same step: the same skin everywhere
            sim.prm = sim.prm._replace(wall_skin=next_wall_skin(wall_travel(sim.clock, sim.prm),
                                                                sim.prm.skin))
        self._build_lists(history)
        sim.n_rebuilds += 1

    def _build_lists(self, history) -> None:
        """The lists of the current rows (``neighbors.build_lists``), grown while they
        overflow; the history from ``history`` if given, else from the current list."""
        sim = self.sim
        from_list = sim.hist > 0 and history is None
        if history is None:
            history = NO_HISTORY
        count, n_wall = -1, -1  # not built yet
        while not (0 <= count <= sim.pairs.i.size and 0 <= n_wall <= sim.pairs.wall.size):
            if count >= 0:  # a build overflowed the lists: grow them, keep the history read
                from_list = False
                sim.pairs = new_pairs(max(count + count // 2, sim.pairs.i.size),
                                      max(n_wall + n_wall // 2, sim.pairs.wall.size), sim.hist)
            count, n_wall, history = build_lists(sim.ps, sim.pairs, sim.clock, sim.prm,
                                                 sim.clock_time, from_list, history,
                                                 sim.options.walls)

    def place_idle_walls(self) -> None:
        """Bring the wall disks the step loop does not move (clock.n_moving onwards) to the
        current time: before a build, and whenever control returns to Python, so that output
        sees every wall disk where it is."""
        sim = self.sim
        first, last = int(sim.clock.n_moving[0]), int(sim.clock.n_local[0])
        if last > first:
            place_wall_disks(sim.ps, first, last, sim.clock_time, sim.prm.rings, False)

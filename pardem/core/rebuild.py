"""The neighbour build between compiled chunks: under MPI first the exchange of migrants and
ghosts (when ``Decomposition.exchange_due`` says so), then the lists (pair list with the
contact history carried over, ring-contact candidates), grown when they overflow.

Stage: neighbour rebuild. Works on a Simulation's state (``sim.ps``, ``pairs``, ``clock``);
called when the step loop returns NEED_REBUILD, at start-up and after a state edit.
"""

from __future__ import annotations

import numpy as np

from ..contact.history import NO_HISTORY
from .memory import unmapped
from .integrate import wall_travel
from .neighbors import build_lists, next_wall_skin
from .state import ROW_ROOM, new_pairs, new_particles, packed, row_width, unpack_particles
from ..walls import place_wall_disks


def rebuild(sim, history=None, rebalance: bool = True, exchange: bool = True) -> None:
    """New neighbour lists; under MPI, if ``exchange``, first migrate particles and
    exchange ghosts (which usually builds the lists too). The history is carried over by
    gid keys (from ``history`` if given, else from the current list)."""
    count, n_wall = -1, -1  # lists not built yet
    if sim.prm.wall_disks:  # every rank builds at the same step: the same skin everywhere
        sim.prm = sim.prm._replace(wall_skin=next_wall_skin(wall_travel(sim.clock, sim.prm),
                                                            sim.prm.skin))
    if sim.decomp.parallel and exchange:
        with unmapped():  # its blocks fit no build's (memory.py)
            history, (count, n_wall) = migrate(sim, history, rebalance)
    from_list = sim.hist > 0 and history is None
    if history is None:
        history = NO_HISTORY
    while not (0 <= count <= sim.pairs.i.size and 0 <= n_wall <= sim.pairs.wall.size):
        if count >= 0:  # a build overflowed the lists: grow them, keep the history read
            from_list = False
            sim.pairs = new_pairs(max(count + count // 2, sim.pairs.i.size),
                               max(n_wall + n_wall // 2, sim.pairs.wall.size), sim.hist)
        count, n_wall, history = build_lists(sim.ps, sim.pairs, sim.clock, sim.prm, sim.clock_time,
                                             from_list, history, sim.options.walls)
    sim.n_rebuilds += 1


def rebuild_on_request(sim) -> None:
    """The build the step loop asks for (NEED_REBUILD): every wall disk placed at the current
    time, then new lists, under MPI with an exchange if ``Decomposition.exchange_due``."""
    place_idle_walls(sim)
    n = int(sim.clock.n_local[0])
    sim._rebuild(exchange=sim.decomp.exchange_due(sim.ps.x[:n]))


def migrate(sim, history, rebalance: bool):
    """Under MPI: migrate owned particles that left the sector, exchange ghosts, lay the
    rows out again as [owned | wall disks | ghosts] and, if they fit, build the lists.
    Returns the history with the migrants' merged in, and (pair count, ring candidate
    count) of the lists, or (-1, -1) if they were not built."""
    clock, ps, hist = sim.clock, sim.ps, sim.hist
    n_owned, n_local, idle = counts = exchange_counts(clock)
    if rebalance:
        sim.decomp.rebalance(ps.x[:n_owned])
    written, moved, own, walls, ghosts, lists, history = sim.decomp.distribute(
        ps, sim.pairs, clock, counts, hist, sim.options.walls, history, sim.clock_time, sim.prm,
        sim.wall_margin)
    if not written:  # ps too small: store the rows in larger arrays
        rows = np.concatenate([own, walls, ghosts] if moved else
                              [packed(ps, np.arange(n_local), hist), ghosts])
        sim.ps = ps = new_particles(int(ROW_ROOM * rows.shape[0]), hist)
        unpack_particles(rows, ps, 0)
        order_walls(sim, idle)  # the wall block keeps its order: the idle ones are last
    sim.decomp.exchanged(sim.ps.x[:int(sim.clock.n_local[0])])  # idle walls placed at t
    return history, lists


def exchange_counts(clock) -> tuple[int, int, int]:
    """(owned rows, owned rows + wall disks, wall disks not moved since the last build)."""
    n_owned, n_local = int(clock.n_owned[0]), int(clock.n_local[0])
    return n_owned, n_local, n_local - int(clock.n_moving[0])


def order_walls(sim, idle: int) -> None:
    """Store the wall disks near this rank's sector first and let the step loop move only
    those (clock.n_moving): within the ghost width plus a wall diameter of the sector, no
    owned particle can touch another wall disk before the next exchange. ``idle``: how
    many wall disks, stored last, the step loop did not move (placed here first)."""
    from ..parallel.exchange import ExchangePlan, arrange_walls

    clock = sim.clock
    n_owned, n_local = int(clock.n_owned[0]), int(clock.n_local[0])
    plan = ExchangePlan(sim.decomp.cut.radii, sim.decomp.cut.edges, sim.decomp.rank, 0.0,
                        sim.wall_margin, row_width(sim.hist), 0, False, False)
    n_near = arrange_walls(sim.ps, n_owned, n_local - idle, n_local, sim.clock_time, sim.prm, plan)
    clock.n_moving[0] = n_owned + n_near


def place_idle_walls(sim) -> None:
    """Bring the wall disks the step loop does not move (clock.n_moving onwards) to the
    current time whenever control returns to Python, so that output sees every wall disk
    where it is."""
    first, last = int(sim.clock.n_moving[0]), int(sim.clock.n_local[0])
    if last > first:
        place_wall_disks(sim.ps, first, last, sim.clock_time, sim.prm.rings, False)

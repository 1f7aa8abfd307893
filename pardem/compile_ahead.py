"""The first run on several ranks: its largest kernels compiled on different ranks at once.

Every rank calls the same kernels, so with a cold numba cache every rank would compile all of
them, one after another, in the same order. Instead:
- ``compile_first``, before the annulus is cut: rank 0 compiles the cut's owner test while
  rank 1 compiles the refresh plan's buffers.
- ``compile_ahead``, before the first exchange: rank 0 compiles the selecting pair loop and
  the ring contacts (``forces.selected_pairs``, ``ring_contacts``), the migration
  (``parallel.exchange``'s ``send_rows``, ``receive_rows`` and ``peer_offsets``), then the
  ring sums of in-situ averaging; rank 1 compiles the progress line's diagnostics, the
  ring-contact and exchange tests (``cut.largest_move``), the two kernels the migration calls
  last (its refresh plan, which rank 0 then finds in the cache, and the list build), the pair
  loop over every pair (``forces.every_pair``, the largest kernel), the force call around the
  loops (whose other kernels it then finds in the cache), the step loop around it
  (``step.make_stepper``'s ``advance``, with the ghost refresh it calls), and the touching-pair
  test of the contact tables.
After a barrier each rank loads the other's from numba's disk cache when it first calls them;
with a warm cache each ``compile`` only loads. The two lists take about as long
(``run_scripts/benchmarks/compile_times.py`` measures the balance). The signatures are those of
the calls that follow (``numba.typeof`` of the same arguments; inside the step loop the switches
are literals; the step loop's refresh plan is an empty one of the same types): a mismatch would
cost only a second compile, which ``tests/test_mpi.py`` checks for.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numba.core import types

from .contact.history import NO_HISTORY
from .core.forces import ForceWork, contact_forces, every_pair, selected_pairs
from .core.neighbors import build_lists
from .parallel import barrier
from .boundaries.ring_forces import ring_contacts


def compile_first(decomp) -> None:
    """Collective, before the annulus is first cut: the two kernels every rank needs before
    ``compile_ahead`` (the cut's owner test; the refresh plan's buffers, for the step loop's
    signature) compiled one per rank instead of both on every rank."""
    if decomp.parallel:
        _compile(decomp, _first_groups(decomp))


def compile_ahead(sim, history) -> None:
    """Collective, before the first neighbour build of a parallel run (``history`` as given to
    that build)."""
    if sim.decomp.parallel:
        _compile(sim.decomp, _groups(sim, history))


def _compile(decomp, groups: list[list]) -> None:
    """Each rank compiles its group (a signature may be a function, called when its turn
    comes), then waits for the others. A kernel that fails to compile here is left to its first
    call, which reports the error on every rank."""
    for kernel, signature in groups[decomp.rank] if decomp.rank < len(groups) else ():
        try:
            kernel.compile(signature() if callable(signature) else signature)
        except Exception:  # noqa: BLE001  (compiled again, and reported, at the call)
            pass
    barrier(decomp.comm)


def _first_groups(decomp) -> list[list]:
    """Per rank, the kernels of ``compile_first`` and their signatures."""
    from .parallel.exchange import halo_buffers, owners  # the kernels of the exchange module

    f8_1d, f8_2d = nb.typeof(np.zeros(2)), nb.typeof(np.zeros((1, 2)))
    plan = types.UniTuple(nb.typeof(np.zeros(1, np.int64)), 4)
    return [[(owners, (f8_2d, f8_1d, f8_2d, types.int64))],
            [(halo_buffers, (plan, nb.typeof(decomp.handles)))]]


def _groups(sim, history) -> list[list]:
    """Per rank, the kernels to compile and their signatures."""
    from .parallel.exchange import _refresh_plan  # loads libmpi: parallel only

    ps, pairs, prm, opts = sim.ps, sim.pairs, sim.prm, sim.options
    exchange = sim.decomp.exchange_arguments(ps, pairs, sim.clock, sim.hist, history,
                                             sim.wall_margin)
    f8, record = types.float64, types.boolean
    rotation, walls = types.literal(opts.rotation), types.literal(opts.walls)
    o = nb.typeof(opts.contact)
    state = (nb.typeof(ps), nb.typeof(pairs))
    halo = sim.decomp.empty_halo()
    lists = state + tuple(nb.typeof(a) for a in (sim.clock, prm, 0.0, False, NO_HISTORY, True))
    positions = types.Array(f8, 2, "A")  # owned rows moved in place or gathered: either layout
    plan = (positions, nb.typeof(NO_HISTORY[0]), nb.typeof(np.zeros((1, 2))), types.int64, f8)
    after_migration, early, late = _first_step(sim, state, f8)
    work = nb.typeof(ForceWork(np.zeros(1), np.zeros((2, 1), np.int32), np.zeros(2, np.int64),
                               np.zeros(3)))
    rows, deep = nb.typeof(np.zeros(1)), nb.typeof(np.zeros(3))
    forces = [(selected_pairs, state + (nb.typeof(prm), f8, o, rotation, work, record)),
              (ring_contacts, state + (nb.typeof(prm), f8, f8, o, rotation, record, deep))]
    return [
        forces + _migration(tuple(nb.typeof(a) for a in exchange)) + after_migration,
        early + [(_refresh_plan, plan), (build_lists, lists),
         (every_pair, state + (nb.typeof(prm), f8, o, rotation, rows, record, types.boolean,
                               deep)),
         (contact_forces, state + (types.int64, nb.typeof(prm), f8, f8, o, rotation, walls,
                                   work, record)),
         (sim.stepper.advance, state + tuple(nb.typeof(a) for a in (sim.clock, prm, halo, 0)))]
        + late,
    ]


def _migration(exchange: tuple) -> list:
    """The compiled calls of ``exchange.exchange_rows`` (``exchange``: the types of its
    arguments); receive_rows takes what send_rows returns."""
    from .parallel.exchange import peer_offsets, receive_rows, send_rows

    ps, pairs, _, counts, plan, from_list, history, handles = exchange
    index = nb.typeof(np.zeros(1, np.int64))

    def receive():
        rbuf, recv_off, owner, sent_history, _ = send_rows.nopython_signatures[-1].return_type
        return (ps, counts, owner, types.Tuple((rbuf, recv_off)), plan, sent_history, handles,
                types.boolean)
    return [(send_rows, (ps, pairs, types.int64, plan, from_list, history, handles)),
            (receive_rows, receive), (peer_offsets, (index, index, index, handles))]


def _first_step(sim, state, f8) -> tuple[list, list, list]:
    """The kernels of the output, averaging and exchange test (compiled lazily otherwise, all
    ranks at once): rank 0's share (after the migration) and rank 1's, before and after its
    list (which starts with the refresh plan that rank 0's migration needs from it)."""
    from .core import diagnostics as diag
    from .parallel.cut import largest_move

    n, prm = types.int64, nb.typeof(sim.prm)
    positions = nb.typeof(sim.ps.x[:1])  # the contiguous leading rows, as exchange_due passes
    after_migration = []
    if sim.rings is not None:
        from averaging.sample import empty_sample
        from averaging.sums import accumulate

        sums = sim.rings.sum_arguments(empty_sample())
        after_migration.append((accumulate, tuple(nb.typeof(a) for a in sums)))
    early = [(diag.kinetic_energy, (state[0], n)), (diag.max_overlap_ratio, state + (prm, f8)),
             (largest_move, (positions, positions))]
    if sim.options.walls:
        early.append((diag.touching_rings, state + (prm, f8)))
    return after_migration, early, [(diag.touching_pairs, state + (n,))]

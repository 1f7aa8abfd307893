"""The first run on several ranks: its largest kernels compiled on different ranks at once.

Every rank calls the same kernels, so with a cold numba cache every rank would compile all of
them, one after another, in the same order. Before the first exchange, rank 0 compiles the
migration (``parallel.exchange.exchange_rows``) while rank 1 compiles the two kernels that
the migration calls last (its refresh plan and the list build, which rank 0 then finds in the
cache), the force loop and the ring contacts (``forces``), and the step loop around them
(``step.make_stepper``'s ``advance``, with the ghost refresh it calls); after a barrier each
rank loads the other's from numba's disk cache when it first calls them. The small kernels
that a run would otherwise compile after its first step, on every rank at once, are shared the
same way, most of them on rank 1, since the migration alone takes rank 0 almost as long as
rank 1's list: the progress line's diagnostics, the ring-contact test and the exchange test
(``cut.largest_move``) first, the ring sums of in-situ averaging last; the touching-pair test of
the contact tables on rank 0 (``run_scripts/compile_times.py`` measures the balance). With a
warm cache
each ``compile`` only loads. The signatures are those of the calls that follow
(``numba.typeof`` of the same arguments; inside the step loop the switches are literals; the
step loop's refresh plan is an empty one of the same types): a mismatch would cost only a
second compile, which ``tests/test_mpi.py`` checks for.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numba.core import types

from .contact.history import NO_HISTORY
from .forces import contact_forces, ring_contacts
from .rebuild import exchange_counts


def compile_ahead(sim, history) -> None:
    """Collective, before the first neighbour build of a parallel run (``history`` as given to
    that build). A kernel that fails to compile here is left to its first call, which reports
    the error on every rank."""
    decomp = sim.decomp
    if not decomp.parallel:
        return
    groups = _groups(sim, history)
    for kernel, signature in groups[decomp.rank] if decomp.rank < len(groups) else ():
        try:
            kernel.compile(signature)
        except Exception:  # noqa: BLE001  (compiled again, and reported, at the call)
            pass
    decomp.comm.Barrier()


def _groups(sim, history) -> list[list]:
    """Per rank, the kernels to compile and their signatures."""
    from .neighbors import build_lists
    from .parallel.exchange import _refresh_plan, exchange_rows  # loads libmpi: parallel only

    ps, pairs, prm, opts = sim.ps, sim.pairs, sim.prm, sim.options
    exchange = sim.decomp.exchange_arguments(ps, pairs, sim.clock, exchange_counts(sim.clock),
                                             sim.hist, opts.walls, history, sim.clock_time, prm,
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
    return [
        [(exchange_rows, tuple(nb.typeof(a) for a in exchange))] + after_migration,
        early + [(_refresh_plan, plan), (build_lists, lists),
         (contact_forces, state + (types.int64, nb.typeof(prm), f8, f8, o, rotation, walls,
                                   nb.typeof(np.zeros(1)), record)),
         (ring_contacts, state + (nb.typeof(prm), f8, f8, o, rotation, record)),
         (sim.stepper.advance, state + tuple(nb.typeof(a) for a in (sim.clock, prm, halo, 0)))]
        + late,
    ]


def _first_step(sim, state, f8) -> tuple[list, list, list]:
    """The kernels of the output, averaging and exchange test (compiled lazily otherwise, all
    ranks at once): rank 0's share, and rank 1's before and after the kernels rank 0 needs from
    it."""
    from . import diagnostics as diag
    from .parallel.cut import largest_move

    n, prm = types.int64, nb.typeof(sim.prm)
    positions = nb.typeof(sim.ps.x[:1])  # the contiguous leading rows, as exchange_due passes
    late = []
    if sim.rings is not None:
        from averaging.sample import empty_sample
        from averaging.sums import accumulate

        sums = sim.rings.sum_arguments(empty_sample())
        late.append((accumulate, tuple(nb.typeof(a) for a in sums)))
    early = [(diag.kinetic_energy, (state[0], n)), (diag.max_overlap_ratio, state + (prm, f8)),
             (largest_move, (positions, positions))]
    if sim.options.walls:
        early.append((diag.touching_rings, state + (prm, f8)))
    return [(diag.touching_pairs, state + (n,))], early, late

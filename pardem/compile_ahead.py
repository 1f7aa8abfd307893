"""The first run on several ranks: its largest kernels compiled on different ranks at once.

Every rank calls the same kernels, so with a cold numba cache every rank would compile all of
them, one after another, in the same order. Before the first exchange, rank 0 compiles the
migration (``parallel.exchange.exchange_rows``, with the list build it calls) while rank 1
compiles the force loop and the ring contacts (``forces``); after a barrier each rank loads
the other's from numba's disk cache when it first calls them. With a warm cache each
``compile`` only loads. The signatures are those of the calls that follow (``numba.typeof`` of
the same arguments; inside the step loop the switches are literals): a mismatch would cost
only a second compile, which ``run_scripts/compile_times.py --detail`` shows per rank.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numba.core import types

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
    from .parallel.exchange import exchange_rows  # loads libmpi: parallel runs only

    ps, pairs, prm, opts = sim.ps, sim.pairs, sim.prm, sim.options
    exchange = sim.decomp.exchange_arguments(ps, pairs, sim.clock, exchange_counts(sim.clock),
                                             sim.hist, opts.walls, history, sim.time, prm,
                                             sim.wall_margin)
    f8, record = types.float64, types.boolean
    rotation, walls = types.literal(opts.rotation), types.literal(opts.walls)
    o = nb.typeof(opts.contact)
    state = (nb.typeof(ps), nb.typeof(pairs))
    return [
        [(exchange_rows, tuple(nb.typeof(a) for a in exchange))],
        [(contact_forces, state + (types.int64, nb.typeof(prm), f8, f8, o, rotation, walls,
                                   nb.typeof(np.zeros(1)), record)),
         (ring_contacts, state + (nb.typeof(prm), f8, f8, o, rotation, record))],
    ]

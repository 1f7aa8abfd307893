"""The step loop's ghost refresh, chosen when the step loop is compiled: on one rank (no plan,
``halo is None``) a no-op with no MPI code at all, so a serial run never loads libmpi; under
MPI the compiled refresh of ``halo.py`` (which loads it)."""

from __future__ import annotations

from numba import types
from numba.extending import overload

from ..core.jit import JIT


def refresh_ghosts(ps, halo, first_ghost, bad_here, disp_here, v2_here, step, timing):
    """Refresh the ghosts ps[first_ghost:] to ``step`` and combine the per-rank flags and
    maxima: ``-> (mpi_error, bad_anywhere, disp, v2)`` (compiled code only). ``timing``:
    ``core.timing``'s switch (on: packing and unpacking timed in Halo.wait)."""
    raise NotImplementedError("called from compiled code only")


@overload(refresh_ghosts, jit_options=JIT)
def _refresh_ghosts(ps, halo, first_ghost, bad_here, disp_here, v2_here, step, timing):
    if isinstance(halo, types.NoneType):
        def serial(ps, halo, first_ghost, bad_here, disp_here, v2_here, step, timing):
            return 0, bad_here, disp_here, v2_here
        return serial
    from .halo import exchange_ghosts  # loads libmpi

    def parallel(ps, halo, first_ghost, bad_here, disp_here, v2_here, step, timing):
        return exchange_ghosts(ps, halo, first_ghost, bad_here, disp_here, v2_here, step,
                               timing)
    return parallel

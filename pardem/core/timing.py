"""Per-stage timers of the step loop, compiled in only when a run asks for them
(``pardem run --timing``, ``Simulation(..., timing=True)``).

Stage: diagnostics. ``Timing`` is a ``@static`` switch inside ``StepOptions``. Off, the step
loop's timer branches are pruned before typing (``step.py``) and the refresh's ``stamp`` and
``lap`` fold to nothing, with no new argument or field: the default loop is compiled from the
same typed code as before the timers existed. On, each stage boundary reads the monotonic
clock (``clock_gettime``, no MPI: a serial run times itself too) and adds the stage's seconds
to an accumulator:

    Clock.deep[DRIFT] (integrate.kick_drift: the kicks and the drift), [REFRESH] (all of
    the ghost refresh), [FORCES], [CLOSING] (the closing kick of a call's last step; the
    others are in DRIFT), [STEPS] (steps timed: the divisor of a per-step figure);
    Halo.wait[PACK], [UNPACK]: the refresh's parts besides the wait (Halo.wait[0], measured
    in every run).

The builds are timed in Python (``Simulation.timers``, ``Rebuilder.exchange_seconds``): they
run a few hundred times less often than a step.
"""

from __future__ import annotations

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, register_jitable

from .static import static

FIRST = 4  # Clock.deep[:FIRST]: the overlap guard's record
DRIFT, REFRESH, FORCES, CLOSING, STEPS = range(FIRST, FIRST + 5)
END = FIRST + 5
PACK, UNPACK = 1, 2  # in Halo.wait


@static
class Timing:
    """``on``: the step loop accumulates its stages' seconds (module docstring)."""

    on: bool = False


@intrinsic
def _monotonic(typingctx):
    """Seconds on CLOCK_MONOTONIC, from a timespec on the caller's stack (libc; no MPI)."""
    def codegen(context, builder, sig, args):
        i32, i64 = ir.IntType(32), ir.IntType(64)
        spec = cgutils.alloca_once(builder, ir.ArrayType(i64, 2))
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(i32, [i32, spec.type]), "clock_gettime")
        builder.call(fn, [ir.Constant(i32, 1), spec])  # CLOCK_MONOTONIC
        zero = ir.Constant(i32, 0)
        sec = builder.load(builder.gep(spec, [zero, zero]))
        nsec = builder.load(builder.gep(spec, [zero, ir.Constant(i32, 1)]))
        dbl = ir.DoubleType()
        return builder.fadd(builder.sitofp(sec, dbl),
                            builder.fmul(builder.sitofp(nsec, dbl), ir.Constant(dbl, 1e-9)))
    return types.float64(), codegen


@register_jitable
def stamp(timing):
    """The monotonic clock (s) if ``timing.on``, else 0.0 (no call)."""
    if timing.on:
        return _monotonic()
    return 0.0


@register_jitable
def lap(timing, timers, slot, since):
    """Add the seconds since ``since`` to timers[slot] and return the clock (timing on);
    nothing (0.0) off."""
    if timing.on:
        now = _monotonic()
        timers[slot] += now - since
        return now
    return 0.0

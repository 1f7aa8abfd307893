"""Stopping a run on SIGINT or SIGTERM, on any rank, without losing anything.

Stage: driver. ``pardem run`` runs inside ``catching_signals``: a signal only records its number
(repeated signals too; nothing is raised inside MPI or compiled code, where an exception on one
rank would leave the others waiting for it). ``Simulation.run`` reads ``requested`` between
compiled chunks (every ~0.25 s of work) and takes the largest over the ranks, so a signal to
any one rank stops every rank at the same step: the writers close as at a normal end (final
checkpoint, snapshot, ring averages so far) and ``Interrupted`` is raised; the command exits
with 128 + the signal's number.
"""

from __future__ import annotations

import contextlib
import signal

_received = [0]  # the last signal's number (0: none)


def _record(signum, frame) -> None:
    _received[0] = signum


@contextlib.contextmanager
def catching_signals(restore: bool = True):
    """Within the block, SIGINT and SIGTERM are recorded instead of acting (main thread only).
    ``restore``: the previous handlers return after it (``pardem.cli.main`` may run inside a
    test). ``pardem run`` ignores the two signals after it instead: a signal after the last
    step (mpiexec sends one to the ranks still running when the first exits non-zero, or a late
    Ctrl-C) must not kill a rank while it finishes. Recording would not last: when the
    interpreter finalises, Python resets the handlers it installed to the default (death by the
    signal) before mpi4py's MPI_Finalize waits for the other ranks; an ignored signal stays
    ignored."""
    _received[0] = 0
    previous = {sig: signal.signal(sig, _record) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        _received[0] = 0  # a later run in this process starts afresh
        for sig, handler in previous.items():
            signal.signal(sig, handler if restore else signal.SIG_IGN)


def requested() -> int:
    """The number of the signal received since the start (0: none)."""
    return _received[0]


class Terminated(KeyboardInterrupt):
    """SIGTERM before the time-step loop (reading the scene, building the state, compiling),
    raised as Python raises KeyboardInterrupt for SIGINT: without it SIGTERM kills the process
    silently (status -15), where a Ctrl-C at the same moment ends with one line and 130."""

    signum = signal.SIGTERM


def _raise_terminated(signum, frame) -> None:
    raise Terminated()


def raise_on_sigterm():
    """From now on SIGTERM raises ``Terminated`` in the main thread (``catching_signals``
    records it instead while it lasts). Returns the previous handler, for ``release_sigterm``."""
    return signal.signal(signal.SIGTERM, _raise_terminated)


def release_sigterm(previous, restore: bool = True) -> None:
    """End ``raise_on_sigterm``: the ``previous`` handler returns, or with ``restore`` false
    SIGTERM stays ignored, as after ``catching_signals(restore=False)`` (and for its reason)."""
    signal.signal(signal.SIGTERM, previous if restore else signal.SIG_IGN)


class Interrupted(Exception):
    """A run stopped by a signal at a step boundary, after its writers closed."""

    def __init__(self, signum: int, time: float, step: int):
        self.signum, self.time, self.step = signum, time, step
        super().__init__(f"stopped by {signal.Signals(signum).name} at t = {time:.6g} s "
                         f"(step {step})")

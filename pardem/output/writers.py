"""Writers fired by triggers between the compiled chunks of a run: snapshots, checkpoints, ring
samples. A writer never changes the state; the run loop (``Simulation.run``) asks each for its
next step, advances to the earliest, and fires the ones that are due, in the order listed.

Stage: output. Triggers are exact step numbers (time = step * dt), so the same states are
written on any number of ranks and after any restart.
"""

from __future__ import annotations

import math

import numpy as np


class Every:
    """Every ``period`` steps (the multiples of it)."""

    def __init__(self, period: int):
        self.period = max(1, int(period))

    def next_after(self, step: int) -> int:
        return (step // self.period + 1) * self.period

    def due(self, step: int) -> bool:
        return step % self.period == 0


class At:
    """At the given steps (ascending)."""

    def __init__(self, steps: np.ndarray):
        self.steps = np.asarray(steps, np.int64)
        self._set = set(self.steps.tolist())

    def next_after(self, step: int) -> int:
        k = np.searchsorted(self.steps, step, side="right")
        return int(self.steps[k]) if k < self.steps.size else math.inf

    def due(self, step: int) -> bool:
        return step in self._set


class Writer:
    """``trigger`` decides when; ``write(sim)`` writes (collective under MPI); ``close(sim)``
    at the end of a run; ``stage``: the timer it is counted in."""

    stage = "output"

    def __init__(self, trigger):
        self.trigger = trigger

    def write(self, sim) -> None:
        raise NotImplementedError

    def close(self, sim) -> None:
        pass


class Snapshots(Writer):
    """Particle and contact snapshots (``Simulation.write_snapshot``); the final state too if
    it is off the snapshot grid by more than 1 % of the period. A snapshot interval that is not
    a whole number of steps puts the grid's last step a few steps from the end (couette_quick:
    one); a second snapshot that close would show the same state twice, and the checkpoint
    holds the exact end state. An end snapshot stands in for the next grid point: a continued
    run's next snapshot replaces it (output/series.py)."""

    stage = "snapshots"

    def write(self, sim) -> None:
        sim.write_snapshot()

    def close(self, sim) -> None:
        period = self.trigger.period
        if sim.step % period > period // 100:
            sim.write_snapshot(end=True)


class Checkpoints(Writer):
    """Checkpoints (``Simulation.write_checkpoint``), and one at the end of every run."""

    stage = "checkpoints"

    def write(self, sim) -> None:
        sim.write_checkpoint()

    def close(self, sim) -> None:
        sim.write_checkpoint()


class RingSamples(Writer):
    """In-situ ring averaging: one sample at each trigger step (collective: one Allreduce);
    rings.h5/.csv/.vtu written at the end (rank 0)."""

    stage = "averaging"

    def __init__(self, trigger, averager, out_dir):
        super().__init__(trigger)
        self.averager = averager
        self.out_dir = out_dir

    def write(self, sim) -> None:
        self.averager.sample(sim)

    def close(self, sim) -> None:
        if self.averager.samples:
            sim.log(self.averager.summary(sim.scene.geometry.outer_radius))
        if self.out_dir is not None and self.averager.samples and sim.decomp.rank == 0:
            self.averager.write(self.out_dir)


def sample_range(start: float, end: float, interval: float, dt: float) -> tuple[int, int, int]:
    """(every, k0, k1): the sample steps are k * every for k0 <= k <= k1, every =
    round(interval/dt), k0 = round(start/(every dt)), k1 = round(end/(every dt)) (k0 - 1 for an
    infinite end: none)."""
    every = max(1, int(round(interval / dt)))
    k0 = int(round(start / (every * dt)))
    k1 = int(round(end / (every * dt))) if math.isfinite(end) else k0 - 1
    return every, k0, k1


def is_sample_step(step: int, start: float, end: float, interval: float, dt: float) -> bool:
    """Whether ``step`` is one of ``sample_range``'s steps (``start`` and ``end`` included):
    the test offline averaging applies to each snapshot, the set the in-situ sampler takes."""
    every, k0, k1 = sample_range(start, end, interval, dt)
    return step % every == 0 and k0 <= step // every <= k1


def sample_steps(start: float, end: float, interval: float, dt: float,
                 last_step: int) -> np.ndarray:
    """The steps of ``sample_range`` up to ``last_step``: evenly spaced samples that coincide
    with snapshots of that interval (an [averaging] end far past the run allocates nothing)."""
    every, k0, k1 = sample_range(start, end, interval, dt)
    return every * np.arange(k0, min(k1, last_step // every) + 1, dtype=np.int64)

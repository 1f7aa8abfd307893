"""The run's warnings: a value that is legal but physically suspicious, named with why it is
suspicious and what to do, in the log (DIR/log.txt) and on stderr (rank 0), never a stop.
Each one is set or silenced by a ``[warnings]`` key (input/warnings_table.py); docs/warnings.md
lists them.

Stage: output. ``RunWarnings`` is built at a Simulation's first run: it gives the warnings of
the set-up (the species' masses, input/sanity.py; more ranks than cores) and then watches the
largest overlap, which the step loop measures after every compiled call (a collective pass
over the pair list that costs about one step, against a call's ~0.25 s of steps).
"""

from __future__ import annotations

import math
import sys

from ..input.sanity import density_warning
from ..parallel import most_crowded_node

OVERSUBSCRIBED_SLOWDOWN = ("measured on a 2-core machine: 4 ranks ran at the speed of 1, half "
                           "that of 2, when it was otherwise idle, and 10 to 50 x slower than 1 "
                           "beside other jobs")
"""What more ranks than cores cost (docs/warnings.md gives the runs)."""


def warn(sim, text: str) -> None:
    """Give one warning: logged, and written to stderr on rank 0."""
    sim.log(f"warning: {text}")
    if sim.decomp.rank == 0:
        sys.stderr.write(f"pardem: warning: {text}\n")
        sys.stderr.flush()


def oversubscription_warning(ranks: int, cores: int) -> str | None:
    """Why ``ranks`` on a node with ``cores`` for them will crawl, or None if each has one."""
    if ranks <= cores:
        return None

    def count(n: int, noun: str) -> str:
        return f"{n} {noun}" if n == 1 else f"{n} {noun}s"

    return (f"{count(ranks, 'rank')} share {count(cores, 'core')} on one node: a rank that "
            "waits for its neighbours' ghosts at every step keeps polling on a core that another "
            f"rank needs, so each step waits for the slowest ({OVERSUBSCRIBED_SLOWDOWN}). Run at "
            f"most {count(cores, 'rank')} per node. ([warnings] oversubscribe = true silences "
            "this, for runs that mean it, such as correctness tests)")


class RunWarnings:
    """A Simulation's warnings, each given once (the overlap once per phase: compression,
    shear). Building it gives the set-up's warnings (collective)."""

    def __init__(self, sim):
        scene = sim.scene
        self.limit = scene.warnings.overlap
        self.t_comp = scene.geometry.compression_time if scene.geometry is not None else None
        # the compression's last step: the step loop stops there, so that its deepest overlap
        # (the densest packing, at the end of the push) is measured within the compression
        self.comp_step = (-1 if self.t_comp is None else
                          math.ceil(self.t_comp / sim.dt * (1.0 - 1e-12)))
        self.given: set[str] = set()
        texts = [density_warning(scene)]
        if not scene.warnings.oversubscribe:
            comm = sim.decomp.comm if sim.decomp.parallel else None
            texts.append(oversubscription_warning(*most_crowded_node(comm)))
        for text in texts:
            if text is not None:
                warn(sim, text)

    def next_after(self, step: int) -> float:
        """The next step after ``step`` at which the overlap must be measured (the end of
        the compression; inf past it)."""
        return self.comp_step if step < self.comp_step else math.inf

    def phase(self, step: int) -> str:
        """"compression" (to its last step), "shear" (after it) or, in a free scene, "run"."""
        if self.t_comp is None:
            return "run"
        return "compression" if step <= self.comp_step else "shear"

    def overlap(self, sim, overlap: float) -> None:
        """Warn if ``overlap`` (the largest, over the smaller free diameter; every rank's
        value) passes [warnings] overlap, the first time in this phase."""
        if self.limit is False or overlap <= self.limit:
            return
        phase = self.phase(sim.step)
        if phase in self.given:
            return
        self.given.add(phase)
        when, remedy = self._when_and_remedy(phase)
        warn(sim, f"t = {sim.time:.4g} s, during {when}: the largest overlap is "
                  f"{100 * overlap:.2f} % of the smaller diameter of its disks, above [warnings] "
                  f"overlap = {100 * self.limit:g} %. The contact law stands for a small elastic "
                  "dent (the paper's packings reach ~1 %); this deep, the forces, contact times "
                  f"and volume fractions no longer follow the material: {remedy}. (Said once "
                  "per phase; [warnings] overlap sets the level, false silences this; at 25 % "
                  "the run stops)")

    def _when_and_remedy(self, phase: str) -> tuple[str, str]:
        """The phase in words and what to do about a deep overlap in it (built for the phase
        at hand only: a free scene has no compression time to name)."""
        stiffer = "stiffen the contact (k_n; youngs_modulus with the Hertz law)"
        if phase == "run":
            return "the run", f"{stiffer}, or slow the disks down"
        if phase == "compression":
            return (f"the compression (to t = {self.t_comp:g} s)",
                    "compress more slowly (a longer compression_time) if the ring's push does "
                    "it, to a lower density (fewer disks, a larger outer_radius) if the packing "
                    f"is too dense for the cell, or {stiffer}")
        return ("the shear (after the compression)",
                f"{stiffer}, shear more slowly (a smaller omega_inner) or make the packing less "
                "dense")

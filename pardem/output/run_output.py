"""Mixed into Simulation: its output between compiled calls, the snapshot series, snapshots,
checkpoints and the in-situ ring sampler's writer (each collective under MPI).

Stage: driver (the writers themselves: output/).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .averages import sample_grid
from .checkpoint import save_checkpoint
from .restart import gather_state
from .series import continue_series
from .snapshots import write_snapshot
from .writers import At, RingSamples


class RunOutput:
    """Output of a Simulation (uses its ``scene``, ``dt``, ``step``, ``decomp``, ``rings``,
    ``out_dir``, ``_series``, ``_end_step`` and its views)."""

    def _ring_writers(self, end_step: int) -> list:
        """The in-situ ring sampler (none without [averaging]) at the sample steps up to
        ``end_step`` that it has not taken: after its last sample (a later run(), a restart:
        the checkpoint's samples are kept), else from this step on, this one included."""
        if self.rings is None:
            return []
        steps = sample_grid(self.scene, self.dt, end_step)
        taken = self.rings.times
        steps = steps[steps > round(taken[-1] / self.dt) if taken else steps >= self.step]
        return [RingSamples(At(steps), self.rings, self.out_dir)]

    @property
    def snapshot_period(self) -> int:
        """Steps between snapshots ([output] snapshot_interval, rounded to whole steps)."""
        return max(1, int(round(self.scene.output.snapshot_interval / self.dt)))

    @property
    def end_snapshot(self) -> bool:
        """Whether the last snapshot is this state's end snapshot, off the snapshot grid: a
        continued run replaces it with its next one (checkpoints keep this)."""
        if self._series is None:
            return self._end_step == self.step
        return self._series.ends_at(self.step)

    def _snapshot_series(self):
        """The series of snapshot files this run continues (collective, once)."""
        if self._series is None:
            self._series = self.decomp.bcast_call(continue_series, self.out_dir, self.step,
                                                  self.snapshot_period, self._end_step,
                                                  self.log)
        return self._series

    def write_snapshot(self, end: bool = False) -> None:
        """The current state into the next snapshot file (collective); ``end``: the end of a
        run off the snapshot grid, a snapshot the next one replaces."""
        index = self._snapshot_series().take(self.step, end)
        contacts = self.contacts()
        with_rings = self.options.walls and self.scene.output.contacts
        ring = self.ring_contacts() if with_rings else None
        arrays = self._particle_table(contacts)
        if self.decomp.rank == 0:
            write_snapshot(self.out_dir, index, self.time, self.step, arrays,
                           contacts if self.scene.output.contacts else None, ring)

    def checkpoint_state(self) -> tuple[dict[str, np.ndarray], dict[str, object]] | None:
        """The whole state gathered on rank 0 (None on the others; output.restart)."""
        return gather_state(self)

    def write_checkpoint(self, path: str | Path | None = None) -> None:
        """The whole state, contact history and ring samples included, into ``path`` (default
        ``out_dir/checkpoint.h5``; collective, rank 0 writes): what ``restart=`` and
        ``branch=`` (``pardem run --restart``, ``--from``) read."""
        state = self.checkpoint_state()
        if state is not None:
            save_checkpoint(path or self.out_dir / "checkpoint.h5", *state)

"""The numbering of a run folder's snapshot files: a running count along the series.

Stage: output (rank 0 reads the folder; every rank keeps the count). File k of
``snapshots/`` is the series' k-th snapshot, not the time over the snapshot interval: a
restart with another ``[output] snapshot_interval`` then appends after the snapshots up to its
checkpoint instead of writing over them or leaving gaps (issue 51, H1). A new series starts
at ceil(step / period), where a run from t = 0 on that grid would have it, so a run continued
into an empty folder, and every run that keeps its interval, numbers its files as the interval
did. Two snapshots take the index of the one before them instead of the next: one of the same
step (a continued run writes its checkpoint's state again), and the one after an end snapshot
off the snapshot grid (``Snapshots.close``: it stood in for the next grid point; a
checkpoint records that its state's snapshot was such an end snapshot, ``end_snapshot``).
A restart also rebuilds the XDMF indexes when they name files that are gone or leave some
out (issue 51, L3), saying so in the log.
"""

from __future__ import annotations

from pathlib import Path

import h5py

from ..input.scene import SceneError
from . import xdmf
from .xdmf import FOLDER, file_name, snapshot_indexes


class Series:
    """The last snapshot of a series: its ``index``, its ``step`` (None before the first; the
    series then starts at ``index + 1``) and whether it is an ``end`` snapshot off the grid."""

    def __init__(self, index: int, step: int | None, end: bool):
        self.index, self.step, self.end = index, step, end

    def take(self, step: int, end: bool) -> int:
        """The index of a snapshot at ``step`` (``end``: off the grid, at the end of a run)."""
        if step == self.step:  # the same state again: a grid snapshot stays one
            self.end = self.end and end
            return self.index
        if not self.end:
            self.index += 1
        self.step, self.end = step, end
        return self.index

    def ends_at(self, step: int) -> bool:
        """Whether the last snapshot is the end snapshot of the state at ``step``."""
        return self.end and self.step == step


def continue_series(out_dir: Path, step: int, period: int, end_step: int | None,
                    log) -> Series:
    """The series a run at ``step`` (snapshots every ``period`` steps) continues in
    ``out_dir``: the last snapshot file of a step up to ``step`` ends it (an end snapshot if at
    ``end_step``, the step of a checkpoint that says so); later files are the abandoned tail
    of a run past the checkpoint, which the first snapshot written drops (``write_snapshot``).
    XDMF indexes out of step with the files kept (a deleted snapshots/, an index cut short)
    are rebuilt from them, and ``log`` says why. SceneError if a file the search reads is not
    a snapshot."""
    stored = snapshot_indexes(out_dir)
    series = None
    for k in range(len(stored) - 1, -1, -1):
        written = _step_of(out_dir / FOLDER / file_name(stored[k]))
        if written <= step:
            series = Series(stored[k], written, written == end_step)
            break
    if series is None:  # a new series, or only a tail to drop, all of it (from file 0 on)
        series, k = Series(-1 if stored else -(-step // period) - 1, None, False), -1
    _mend_indexes(out_dir, stored[:k + 1], log)
    return series


def _mend_indexes(out_dir: Path, kept: list[int], log) -> None:
    found = xdmf.problems(out_dir, kept)
    if not found:
        return
    xdmf.rebuild(out_dir, kept[-1] if kept else -1)
    log("continuing the snapshot series: " + "; ".join(found) + (
        f": both indexes rebuilt from the {len(kept)} snapshot files {file_name(kept[0])} to "
        f"{file_name(kept[-1])}" if kept else f": no snapshot files in {FOLDER}/ to index, "
        "both indexes removed; the run writes new ones"))


def _step_of(path: Path) -> int:
    try:
        with h5py.File(path, "r") as h5:
            return int(h5.attrs["step"])
    except (OSError, KeyError, ValueError, TypeError) as e:
        raise SceneError(f"{path}: not a readable snapshot ({e}); move it out of "
                         f"{path.parent} for the run to continue its series") from None

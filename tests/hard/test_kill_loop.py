"""Snapshots survive SIGKILL at any moment: a short run of run_scripts/tools/kill_loop.py (the full
loop, 500 kills on 1 and 2 ranks, is a benchmark-style script; its counts are in
docs/output.md). Every kill must leave a series equal, file for file, to an uninterrupted
run's, and the runs continued from the kills' checkpoints must end in that run's state."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "run_scripts" / "tools"))
from kill_loop import kill_loop  # noqa: E402

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("ranks", [1, 2])
def test_random_kills_never_corrupt_the_series(ranks, tmp_path):
    counts = kill_loop(kills=12, ranks=ranks, work=tmp_path, seed=ranks, steps=60,
                       checkpoint_every=10, say=print)
    assert counts["kills"] == 12, counts
    assert counts["while_writing"] >= 6, counts  # most kills must strike a run that writes
    assert counts["corrupted"] == 0, counts  # the problems found are printed above

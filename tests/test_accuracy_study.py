"""The accuracy study's short version (tiny inputs, about half a minute), so the script behind
docs/accuracy.md cannot rot: every section but the ranks table (the quick settings run no
MPI benchmark; section 5 comes from run_scripts/benchmarks/bench.py, which the MPI tests cover)
runs and writes finite numbers and its plots."""

import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent


@pytest.mark.timeout(1800)  # compiles several integrator variants (cold cache: minutes)
def test_quick_accuracy_study_writes_every_section(tmp_path):
    sys.path.insert(0, str(ROOT / "run_scripts" / "studies"))
    import accuracy_study

    assert accuracy_study.main(["--quick", "--run", str(tmp_path / "none"),
                                "--out", str(tmp_path)]) == 0
    text = (tmp_path / "accuracy.md").read_text()
    for title in ("## 0. Defaults and why", "## 1. Time step and integrator",
                  "## 2. Neighbour skin", "## 3. Ring averaging", "## 4. Sampling interval"):
        assert title in text
    for png in ("time_step.png", "averaging.png", "sampling.png"):
        assert (tmp_path / "accuracy" / png).stat().st_size > 10_000
    rows = [line for line in text.splitlines() if line.startswith("| verlet")]
    assert len(rows) == 4
    for row in rows:  # error and cost columns are numbers
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert all(re.fullmatch(r"[0-9.e+-]+", c) for c in cells[2:5] + cells[7:])
    assert (tmp_path / "accuracy" / "results.json").exists()

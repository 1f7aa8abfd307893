"""Restarts that change the output settings (issue 51: H1): nothing written before the
checkpoint is lost."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from helpers import couette_scene

import pardem
from pardem.simulation import Simulation

CELL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
        "compression_time": 0.1, "omega_inner": 3.0}


def cell(snapshot_interval=0.01, averaging=None):
    # 0.01 s is 230 steps of the automatic dt: every time below lies on the step grid
    return couette_scene(counts=(260, 40), geometry=CELL, averaging=averaging,
                         output={"snapshot_interval": snapshot_interval,
                                 "checkpoint_interval": 0.05})


def index_times(out):
    """The times particles.xdmf lists, in its order; every file it names must exist."""
    grids = ET.parse(out / "particles.xdmf").getroot().find("Domain").find("Grid")
    for item in grids.iter("DataItem"):
        assert (out / item.text.split(":")[0]).exists(), item.text
    return [float(g.find("Time").get("Value")) for g in grids.findall("Grid")]


def centis(*ks):
    """k / 100 s: the double nearest to each decimal time, as the snapshots store it."""
    return [k / 100 for k in ks]


@pytest.mark.parametrize("before, after, want", [
    # doubled: 0.15 lies on the first run's grid, not on the second's: kept
    (0.01, 0.02, centis(*range(0, 16), *range(16, 31, 2))),
    # halved: the first run's end snapshot at 0.15 (off its grid) is rewritten at 0.15
    (0.02, 0.01, centis(*range(0, 15, 2), *range(15, 31))),
    # unchanged (as before the fix): the end snapshot off the grid gives way to the next
    (0.02, 0.02, centis(*range(0, 15, 2), *range(16, 31, 2))),
])
def test_a_restart_with_another_snapshot_interval_keeps_every_earlier_snapshot(
        tmp_path, before, after, want):
    """H1: run to 0.15 s, restart to 0.3 s with another [output] snapshot_interval. The files of
    the first run (up to its checkpoint) stay as they were, the continued run's follow them,
    and the files and particles.xdmf list every time once, in order."""
    out = tmp_path / "run"
    first = Simulation(cell(before), out_dir=out)
    first.run(end=0.15, progress=False)
    kept = {s["step"]: s["position"] for s in pardem.read_snapshots(out)}
    again = Simulation(cell(after), out_dir=out, restart=out)
    again.run(end=0.3, progress=False)
    snaps = list(pardem.read_snapshots(out))
    assert [s["time"] for s in snaps] == want
    assert index_times(out) == want
    for s in snaps:  # the first run's states are still there, bit for bit
        if s["step"] in kept:
            np.testing.assert_array_equal(s["position"], kept[s["step"]])
    names = sorted(p.name for p in (out / "snapshots").iterdir())
    assert names == [f"{i:06d}.h5" for i in range(len(want))]  # a series without holes

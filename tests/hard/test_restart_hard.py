"""Restarts that change the output settings or find the output folder damaged (issue 51: H1,
M1, L3): nothing written before the checkpoint is lost, the indexes name the files on disk,
and the ring averages continue as if the run had not stopped."""

import shutil
import xml.etree.ElementTree as ET

import h5py
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


def test_averaging_from_t0_restarts_and_offline_takes_the_same_samples(tmp_path):
    """M1: [averaging] start = 0. The in-situ samples are t = 0, 0.01, ..., 0.1 (start and
    end included, as the restart check and offline averaging count them); a run cut at 0.05 s
    and restarted (kill -9 or not, the checkpoint is the same) is accepted and writes the
    uninterrupted run's rings.h5; offline averaging of the snapshots (taken at the sample
    times) gives the same samples."""
    from averaging.io import read_rings
    from averaging.offline import average_run

    avg = {"start": 0.0, "end": 0.6, "sample_interval": 0.01}
    ref = Simulation(cell(averaging=avg), out_dir=tmp_path / "ref")
    ref.run(end=0.1, progress=False)
    live = read_rings(tmp_path / "ref")
    assert live["times"].tolist() == centis(*range(11))
    cut = Simulation(cell(averaging=avg), out_dir=tmp_path / "cut")
    cut.run(end=0.05, progress=False)
    again = Simulation(cell(averaging=avg), out_dir=tmp_path / "cut",
                       restart=tmp_path / "cut")
    again.run(end=0.1, progress=False)
    continued = read_rings(tmp_path / "cut")
    for key in live:
        np.testing.assert_array_equal(continued[key], live[key], key)
    offline = average_run(tmp_path / "ref")
    assert offline.times == live["times"].tolist()
    sums = np.array(offline.samples).reshape(live["sums"].shape)
    scale = np.abs(live["sums"]).max(axis=(0, 1))
    assert np.all(np.abs(sums - live["sums"]) <= 1e-12 * scale)


def test_a_restart_after_the_snapshots_were_deleted_indexes_only_existing_files(tmp_path):
    """L3: the user deleted snapshots/ after a run to 0.1 s; the restart to 0.15 s writes
    0.1 ... 0.15, and the indexes name those files only (and the log says what was missing)."""
    out = tmp_path / "run"
    Simulation(cell(), out_dir=out).run(end=0.1, progress=False)
    shutil.rmtree(out / "snapshots")
    Simulation(cell(), out_dir=out, restart=out).run(end=0.15, progress=False)
    want = centis(*range(10, 16))
    assert [s["time"] for s in pardem.read_snapshots(out)] == want
    assert index_times(out) == want
    contacts = ET.parse(out / "contacts.xdmf").getroot()
    for item in contacts.iter("DataItem"):
        assert (out / item.text.split(":")[0]).exists(), item.text
    log = (out / "log.txt").read_text()
    assert ("particles.xdmf named 11 snapshot files (000000.h5 to 000010.h5) that are not "
            "in snapshots/" in log)


def test_a_restart_after_the_index_was_cut_short_indexes_every_snapshot(tmp_path):
    """L3: particles.xdmf cut short (a full disk, an editor) after a run to 0.1 s: the restart
    to 0.15 s indexes all 16 snapshots, not the few the damaged index still held."""
    out = tmp_path / "run"
    Simulation(cell(), out_dir=out).run(end=0.1, progress=False)
    index = out / "particles.xdmf"
    index.write_bytes(index.read_bytes()[:len(index.read_bytes()) * 2 // 3])
    Simulation(cell(), out_dir=out, restart=out).run(end=0.15, progress=False)
    want = centis(*range(16))
    assert [s["time"] for s in pardem.read_snapshots(out)] == want
    assert index_times(out) == want
    log = (out / "log.txt").read_text()
    assert "particles.xdmf was cut short" in log and "rebuilt" in log
    with h5py.File(out / "snapshots" / "000015.h5") as h5:
        assert h5.attrs["time"] == 0.15

"""Nothing is lost and nothing damaged is used: corrupted checkpoints are refused with the file
named, and a run killed with SIGKILL continues from its last checkpoint bit for bit."""

import subprocess
import sys

import h5py
import numpy as np
import pytest
from helpers import couette_scene, kill_when

import pardem
from pardem.scene import SceneError, write_scene
from pardem.simulation import Simulation

CELL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
        "compression_time": 0.1, "omega_inner": 3.0}


def cell(**output):
    return couette_scene(counts=(260, 40), geometry=CELL, output=output)


@pytest.fixture
def checkpoint(tmp_path):
    sim = Simulation(cell(), out_dir=tmp_path)
    sim.run(end=0.12, progress=False)
    return tmp_path / "checkpoint.h5"


def damaged(checkpoint, tmp_path, edit):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(checkpoint.read_bytes())
    with h5py.File(bad, "r+") as h5:
        edit(h5)
    return bad


@pytest.mark.parametrize("what,edit,message", [
    ("garbage in a position", lambda h5: h5["x"].__setitem__((5, 0), np.nan),
     "non-finite x in row 5"),
    ("garbage in a spring", lambda h5: h5["pair_hist"].__setitem__((0, 1), np.inf),
     "non-finite pair_hist in row 0"),
    ("a radius changed", lambda h5: h5["radius"].__setitem__(3, 1.0), "radius of particle row 3"),
    ("particles swapped", lambda h5: h5["gid"].__setitem__(slice(0, 2), [1, 0]),
     "gid of particle row 0"),
    ("springs of non-pairs", lambda h5: h5["pair_hi"].__setitem__(0, -1),
     "pair_lo/pair_hi are not pairs"),
    # what an adversarial user tried: wall disks moved inside the inner ring, a step far in the
    # future, attributes and datasets missing or of another shape, a dataset replaced by a group
    ("wall disks moved", lambda h5: h5["e0"].__setitem__(slice(300, None), h5["e0"][300:] * 0.5),
     "e0 of particle row 300"),
    ("step 1e15", lambda h5: h5.attrs.__setitem__("step", 10**15),
     "step 1000000000000000, dt"),
    ("a negative step", lambda h5: h5.attrs.__setitem__("step", -1), "do not agree"),
    ("no fingerprint", lambda h5: h5.attrs.__delitem__("fingerprint"),
     "it lacks attribute 'fingerprint'"),
    ("x of shape (N, 3)", lambda h5: (h5.__delitem__("x"), h5.create_dataset(
        "x", data=np.zeros((426, 3)))), "x has shape (426, 3) of float64, expected (426, 2)"),
    ("a 1-D history", lambda h5: (h5.__delitem__("pair_hist"), h5.create_dataset(
        "pair_hist", data=np.zeros(7))), "pair_hist has shape (7,)"),
    ("strings for masses", lambda h5: (h5.__delitem__("mass"), h5.create_dataset(
        "mass", data=np.array([b"m"] * 426))), "mass has shape (426,) of |S1"),
    ("a group for a dataset", lambda h5: (h5.__delitem__("omega"), h5.create_group("omega")),
     "'omega' is a group, not a dataset"),
])
def test_corrupted_checkpoint_is_refused(checkpoint, tmp_path, what, edit, message):
    bad = damaged(checkpoint, tmp_path, edit)
    with pytest.raises(SceneError) as err:
        Simulation(cell(), restart=bad)
    assert str(bad) in str(err.value) and "corrupted checkpoint" in str(err.value), what
    assert message in str(err.value), what


def test_checkpoint_with_overwritten_bytes_is_refused(checkpoint, tmp_path):
    """Bytes overwritten inside the file (a disk error): either HDF5 notices, or the contents
    fail the checks; never a silent restart from garbage."""
    data = bytearray(checkpoint.read_bytes())
    with h5py.File(checkpoint) as h5:
        offset = h5["x"].id.get_offset()  # the positions' bytes
    data[offset + 80:offset + 160] = b"\xff" * 80  # ten doubles become NaN
    bad = tmp_path / "bytes.h5"
    bad.write_bytes(bytes(data))
    with pytest.raises(SceneError, match=str(bad)):
        Simulation(cell(), restart=bad)


def test_kill_9_then_restart_reproduces_the_uninterrupted_run(tmp_path):
    """A reference run to 0.6 s; a second run of the same scene killed with SIGKILL while it
    writes; --restart from its last checkpoint to 0.6 s gives the reference state bit for bit,
    and every snapshot written before the kill is readable."""
    scene = tmp_path / "s.toml"
    write_scene(cell(snapshot_interval=0.02, checkpoint_interval=0.1), scene)
    cli = [sys.executable, "-m", "pardem.cli", "run", str(scene), "--quiet"]
    ref = subprocess.run(cli + ["--out", str(tmp_path / "ref"), "--end", "0.6"],
                         capture_output=True, text=True, timeout=300)
    assert ref.returncode == 0, ref.stderr
    out = tmp_path / "killed"
    proc = subprocess.Popen(cli + ["--out", str(out), "--end", "5.0"], stderr=subprocess.DEVNULL)

    def after_first_checkpoints():  # the one at 0.2 s: in the middle of a run
        if not (out / "checkpoint.h5").exists():
            return False
        with h5py.File(out / "checkpoint.h5") as h5:
            return h5.attrs["time"] > 0.15

    reached, exited = kill_when(proc, after_first_checkpoints)
    assert reached and exited is None, (
        f"the run to be killed {'exited with ' + str(exited) if exited is not None else 'ran'} "
        "without reaching its 0.2 s checkpoint in time")
    before = list(pardem.read_snapshots(out))
    assert len(before) >= 10 and all(np.isfinite(s["position"]).all() for s in before)
    with h5py.File(out / "checkpoint.h5") as h5:
        t_ckpt = float(h5.attrs["time"])
    assert t_ckpt < 0.6
    again = subprocess.run(cli + ["--out", str(out), "--end", "0.6", "--restart",
                                  str(out / "checkpoint.h5")],
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    with h5py.File(tmp_path / "ref" / "checkpoint.h5") as a, \
            h5py.File(out / "checkpoint.h5") as b:
        assert a.attrs["step"] == b.attrs["step"]
        for key in a:
            np.testing.assert_array_equal(a[key][()], b[key][()], key)
    # the snapshots before the checkpoint are the ones written before the kill
    after = {s["step"]: s for s in pardem.read_snapshots(out)}
    for s in before:
        if s["time"] <= t_ckpt:
            np.testing.assert_array_equal(after[s["step"]]["position"], s["position"])

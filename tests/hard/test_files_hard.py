"""Nothing is lost and nothing damaged is used: corrupted checkpoints are refused with the file
named, and a run killed with SIGKILL continues from its last checkpoint bit for bit."""

import json
import os
import subprocess
import sys
import time
import zlib

import h5py
import numpy as np
import pytest
from helpers import couette_scene, kill_when

import pardem
from pardem.input.scene import SceneError
from pardem.input.scene_file import write_scene
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


def damaged(checkpoint, tmp_path, edit, checksums=True):
    """A copy of ``checkpoint`` edited by ``edit``; ``checksums``: with the checksums written
    anew for the edited data, as a deliberate edit would, so that the checks behind them are
    what refuses it."""
    bad = tmp_path / "bad.h5"
    bad.write_bytes(checkpoint.read_bytes())
    with h5py.File(bad, "r+") as h5:
        edit(h5)
        if checksums:
            h5.attrs["checksums"] = json.dumps({k: zlib.crc32(np.ascontiguousarray(
                h5[k][()]).view(np.uint8).reshape(-1)) for k in h5.keys()
                if isinstance(h5[k], h5py.Dataset)})
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
    ("a negative step", lambda h5: h5.attrs.__setitem__("step", -1),
     "attribute 'step' is -1, expected a whole number >= 0"),
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


def test_an_edit_that_leaves_the_checksums_is_refused_by_them(checkpoint, tmp_path):
    """The same edit as "garbage in a position" without new checksums: the reader names the
    dataset whose bytes changed before it looks at any value."""
    bad = damaged(checkpoint, tmp_path, lambda h5: h5["x"].__setitem__((5, 0), 1.0),
                  checksums=False)
    with pytest.raises(SceneError, match="dataset 'x' does not match its checksum"):
        Simulation(cell(), restart=bad)


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


def test_a_folder_in_use_is_refused_and_freed_by_any_end_of_its_job(tmp_path):
    """The folder lock: a second holder is refused, naming the first; closing frees it, and so
    does SIGKILL of the holding process (the kernel drops an flock with the process)."""
    from pardem.output.folder import FolderLock

    first, second = FolderLock(tmp_path), FolderLock(tmp_path)
    first.acquire()
    with pytest.raises(SceneError, match=rf"--out {tmp_path}: the folder is in use by pardem "
                                         rf"job {os.getpid()} on "):
        second.acquire()
    first.release()
    second.acquire()
    second.release()
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time; from pathlib import Path; from pardem.output.folder import "
        "FolderLock; FolderLock(Path(sys.argv[1])).acquire(); print('held', flush=True); "
        "time.sleep(600)"), str(tmp_path)], stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held"
    with pytest.raises(SceneError, match=rf"in use by pardem job {holder.pid} "):
        FolderLock(tmp_path).acquire()
    holder.kill()
    holder.wait(timeout=30)
    holder.stdout.close()
    freed = FolderLock(tmp_path)
    freed.acquire()  # freed by the kill
    freed.release()


def test_a_second_job_into_a_running_jobs_folder_is_refused(tmp_path, capsys):
    """Two runs into one folder (or a restart into a folder whose job still writes): the second
    exits 2 naming the first, which goes on writing undisturbed."""
    from pardem.cli import main

    scene = tmp_path / "s.toml"
    write_scene(cell(snapshot_interval=0.02, checkpoint_interval=0.1), scene)
    out = tmp_path / "run"
    cli = [sys.executable, "-m", "pardem.cli", "run", str(scene), "--quiet", "--out", str(out)]
    proc = subprocess.Popen(cli + ["--end", "50"], stderr=subprocess.DEVNULL)
    try:
        def writing():
            return (out / "checkpoint.h5").exists()

        deadline = time.time() + 300
        while not writing() and time.time() < deadline and proc.poll() is None:
            time.sleep(0.05)
        assert writing(), "the first job never wrote a checkpoint"
        for args in (["--overwrite"], ["--restart", str(out)]):
            assert main(["run", str(scene), "--out", str(out), "--end", "0.3", *args]) == 2
            err = capsys.readouterr().err
            assert f"--out {out}: the folder is in use by pardem job {proc.pid} on " in err
        assert proc.poll() is None  # still running
    finally:
        proc.kill()
        proc.wait(timeout=30)
    assert main(["run", str(scene), "--out", str(out), "--end", "0.3", "--restart", str(out),
                 "--quiet"]) == 0  # the killed job's folder continues


def test_a_folder_claimed_twice_is_written_by_the_first_runner_only(tmp_path):
    """Two jobs claim the same empty folder (the second while the first still compiles); the
    first to run writes its run; the other is refused when it starts to run, instead of writing
    over the finished run."""
    out = tmp_path / "run"
    first = Simulation(cell(), out_dir=out)
    second = Simulation(cell(), out_dir=out, overwrite=True)
    first.run(end=0.02, progress=False)
    with pytest.raises(SceneError, match=rf"--out {out}: another job wrote checkpoint.h5, "
                                         r".*snapshots"):
        second.run(end=0.02, progress=False)
    assert [s["time"] for s in pardem.read_snapshots(out)][-1] == pytest.approx(0.02, abs=1e-4)
    first.run(end=0.04, progress=False)  # the first job goes on writing its own run

"""The command line: a short run writes its files; bad input fails with one clear message."""

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

import pardem
from pardem.cli import main

SCENES = Path(__file__).parent / "scenes"


def test_run_writes_snapshots_checkpoint_and_resolved_scene(tmp_path, capsys):
    assert main(["run", str(SCENES / "two_small.toml"), "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "steps/s" in err and "ETA" in err and "max overlap" in err and "E_kin" in err
    assert "time per stage" in err and "forces+integration" in err
    snaps = list(pardem.read_snapshots(tmp_path))
    scene = pardem.load_scene(tmp_path / "scene.toml")
    assert scene.fingerprint() == pardem.load_scene(SCENES / "two_small.toml").fingerprint()
    times = [s["time"] for s in snaps]
    assert times[0] == 0.0 and times[-1] == pytest.approx(scene.time.end, abs=1e-3)
    assert np.all(np.diff(times) > 0)
    first = snaps[0]
    np.testing.assert_array_equal(first["id"], [0, 1])
    assert first["position"].shape == (2, 2) and first["velocity"][0, 0] == 0.05
    with h5py.File(tmp_path / "checkpoint.h5") as h5:
        assert h5.attrs["time"] == pytest.approx(scene.time.end, abs=1e-3)
    # the collision happened: velocities reversed and reduced by e_n ~ 0.22
    assert snaps[-1]["velocity"][0, 0] < 0 < snaps[-1]["velocity"][1, 0]
    log = (tmp_path / "log.txt").read_text().splitlines()
    assert f"run {scene.info.name}: t = 0 s to {scene.time.end:g} s, 2 particles" in log[0]
    assert any("steps/s" in line and "max overlap" in line for line in log)
    assert any("time per stage" in line for line in log) and "forces+integration" in log[-6]


def test_snapshot_contacts_balance_particle_forces(tmp_path):
    """During the collision, the contact table's forces are the particles' forces."""
    main(["run", str(SCENES / "two_small.toml"), "--out", str(tmp_path), "--quiet"])
    touching = [s for s in pardem.read_snapshots(tmp_path) if s["contacts"]["ids"].shape[0]]
    assert touching, "no snapshot caught the collision"
    for s in touching:
        c = s["contacts"]
        assert c["overlap"][0] > 0
        np.testing.assert_array_equal(s["coordination"], [1, 1])


@pytest.mark.parametrize("patch,message", [
    ("k_n = 352.1", "k_n = -1.0"),
    ("mu = 0.0", "mu = -0.1"),
])
def test_bad_scene_exits_2_with_message(tmp_path, capsys, patch, message):
    text = (SCENES / "two_small.toml").read_text()
    assert patch.split(" = ")[0] in text
    bad = tmp_path / "bad.toml"
    key = patch.split(" = ")[0]
    lines = [(message if line.strip().startswith(key + " ") or line.strip().startswith(key + "=")
              else line) for line in text.splitlines()]
    bad.write_text("\n".join(lines))
    assert main(["run", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "error" in err and key in err


def test_unwritable_output_folder_is_refused(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["run", str(SCENES / "two_small.toml"), "--out", str(blocker / "sub")]) == 2
    assert "--out" in capsys.readouterr().err


def test_console_script_runs(tmp_path):
    exe = Path(sys.executable).parent / "pardem"
    r = subprocess.run([str(exe), "run", str(SCENES / "two_small.toml"), "--out", str(tmp_path),
                        "--end", "0.01", "--quiet"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "checkpoint.h5").exists()


def test_more_particles_than_fit_is_refused(tmp_path, capsys):
    scene = (Path(__file__).parents[1] / "run_scripts" / "couette_quick.toml").read_text()
    bad = tmp_path / "crowded.toml"
    bad.write_text(scene.replace("count = 2545", "count = 25450"))
    assert main(["run", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "cannot place 25844 particles" in err and "outer_start_radius" in err

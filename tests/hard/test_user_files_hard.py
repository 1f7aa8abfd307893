"""A user's own files, odd folders and damaged output: pardem removes only what it wrote,
and every refusal is one line with an exit status, never a traceback (issue [ROBUST] M2-M5,
L2)."""

import os
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
from helpers import couette_scene
from mpi_helpers import mpiexec

from pardem.cli import main
from pardem.input.scene import SceneError
from pardem.input.schema import scene_from_dict
from pardem.input.scene_file import write_scene

SMALL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 3.0}


def _small(tmp_path, averaging=None, name="small.toml"):
    """The issue's small.toml: 300 disks, compressed in 0.1 s; returns its path."""
    scene = couette_scene(counts=(300, 0), geometry=SMALL, averaging=averaging,
                          output={"snapshot_interval": 0.01, "checkpoint_interval": 0.05},
                          name="small")
    path = tmp_path / name
    write_scene(scene, path)
    return path


def _one_line(err: str) -> None:
    """One error line (after pardem's set-up line, if any), no traceback."""
    lines = [x for x in err.strip().splitlines() if not x.startswith("pardem: small: building")]
    assert len(lines) == 1 and lines[0].startswith("pardem: error") and "Traceback" not in err, err


def test_overwrite_never_removes_a_users_own_files(tmp_path, capsys):
    """`--out .` beside the user's own scene.toml and rings.csv: refused, both untouched
    (before, --overwrite replaced the scene with the resolved one and deleted the table)."""
    scene = _small(tmp_path, name="scene.toml")
    mine = "# my own notes\n" + scene.read_text()
    scene.write_text(mine)
    (tmp_path / "rings.csv").write_text("my,table\n1,2\n")
    assert main(["run", str(scene), "--out", str(tmp_path), "--end", "0.01", "--quiet",
                 "--overwrite"]) == 2
    err = capsys.readouterr().err
    _one_line(err)
    assert "rings.csv, scene.toml not written by pardem" in err
    assert scene.read_text() == mine
    assert (tmp_path / "rings.csv").read_text() == "my,table\n1,2\n"


def test_overwrite_replaces_pardems_own_run_also_from_before_the_manifest(tmp_path, capsys):
    scene, out = _small(tmp_path), tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--end", "0.02", "--quiet"]) == 0
    assert (out / ".pardem-files").exists()
    (out / ".pardem-files").unlink()  # a folder of an earlier version: no manifest
    assert main(["run", str(scene), "--out", str(out), "--end", "0.01", "--quiet",
                 "--overwrite"]) == 0
    assert "removed the previous run's" in (out / "log.txt").read_text()


def test_symlinked_snapshots_are_refused_not_followed(tmp_path, capsys):
    scene, out = _small(tmp_path), tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--end", "0.02", "--quiet"]) == 0
    elsewhere = tmp_path / "elsewhere"
    (out / "snapshots").rename(elsewhere)
    (out / "snapshots").symlink_to(elsewhere)
    kept = sorted(p.name for p in elsewhere.iterdir())
    capsys.readouterr()
    assert main(["run", str(scene), "--out", str(out), "--end", "0.01", "--quiet",
                 "--overwrite"]) == 2
    err = capsys.readouterr().err
    _one_line(err)
    assert "snapshots not written by pardem" in err
    assert sorted(p.name for p in elsewhere.iterdir()) == kept


def test_a_sample_interval_longer_than_the_window_is_refused():
    d = {"scene": {"kind": "couette", "name": "x"}, "averaging": {"start": 180.0, "end": 239.0,
                                                                   "sample_interval": 1e300}}
    with pytest.raises(SceneError, match=r"\[averaging\] sample_interval = 1e\+300.*longer "
                                         r"than the averaging window end - start = 59 s"):
        scene_from_dict(d)


def test_huge_equal_shares_split_the_count_evenly():
    """share = 1e308 for both species overflowed the sum (ZeroDivisionError)."""
    d = {"scene": {"kind": "couette", "name": "x"}, "geometry": {"volume_fraction": 0.8},
         "species": [{"name": "a", "diameter": 7.42e-3, "mass": 2.75e-4, "share": 1e308},
                     {"name": "b", "diameter": 7.42e-3, "mass": 2.75e-4, "share": 1e308}]}
    a, b = scene_from_dict(d).species
    assert abs(a.count - b.count) <= 1 and a.count > 1000


def test_a_checkpoint_h5py_cannot_iterate_is_refused_in_one_line(tmp_path, capsys,
                                                                  monkeypatch):
    """A bit-flipped checkpoint made h5py raise RuntimeError ("Link iteration failed")."""
    scene, out = _small(tmp_path), tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--end", "0.05", "--quiet"]) == 0

    class Damaged(h5py.File):
        def keys(self):
            raise RuntimeError("Link iteration failed (wrong B-tree signature)")

    import pardem.output.checkpoint as checkpoint

    monkeypatch.setattr(checkpoint.h5py, "File", Damaged)
    capsys.readouterr()
    assert main(["run", str(scene), "--out", str(out), "--restart", str(out), "--end", "0.06",
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    _one_line(err)
    assert "unreadable or truncated checkpoint (Link iteration failed" in err


def test_render_of_a_truncated_snapshot_is_one_line(tmp_path, capsys):
    pytest.importorskip("pyvista")
    scene, out = _small(tmp_path), tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--end", "0.02", "--quiet"]) == 0
    last = sorted((out / "snapshots").iterdir())[-1]
    last.write_bytes(last.read_bytes()[:300])
    capsys.readouterr()
    assert main(["render", str(out)]) == 2
    err = capsys.readouterr().err
    _one_line(err)
    assert "its output files cannot be read" in err


@pytest.fixture(scope="module")
def compressed_only(tmp_path_factory):
    """Averages taken during the compression only: no disk reaches the inner ring yet."""
    tmp = tmp_path_factory.mktemp("compressing")
    scene = _small(tmp, averaging={"start": 0.0, "end": 0.03, "sample_interval": 0.01})
    out = tmp / "run"
    assert main(["run", str(scene), "--out", str(out), "--end", "0.03", "--quiet"]) == 0
    return out


def test_plot_with_no_inner_ring_torque(compressed_only, capsys):
    """The torque balance is normalised by the inner ring's torque: 0 raised
    ZeroDivisionError; now the figure says there is nothing to normalise by."""
    import averaging.report as report

    assert float(report.read_rings(compressed_only)["inner_torque"]) == 0.0
    assert main(["plot", str(compressed_only), "--out", str(compressed_only / "f")]) == 0
    assert (compressed_only / "f" / "check_torque_balance.png").exists()


def test_average_into_a_full_disk_is_one_line_and_leaves_nothing(compressed_only, capsys,
                                                                 monkeypatch):
    """No room for the ring files: refused before h5py writes (which flooded tracebacks and
    segfaulted), exit 4, no rings.h5.tmp, nothing replaced."""
    import pardem.output.atomic as atomic

    monkeypatch.setattr(atomic.shutil, "disk_usage",
                        lambda path: type("U", (), {"free": 1000})())
    out = compressed_only / "offline-full"
    assert main(["average", str(compressed_only), "--out", str(out)]) == 4
    err = capsys.readouterr().err
    _one_line(err)
    assert "No space left on device" in err and f"{out}/rings.h5" in err
    assert not list(out.glob("rings.*"))


@pytest.mark.long
def test_a_file_size_limit_under_mpi_is_one_line_and_exit_4(tmp_path):
    """`ulimit -f` (EFBIG) on 2 ranks: like a full disk, exit 4 from mpiexec with the file
    named (before: a traceback, and MPI_Abort's exit 1). The limit is set after MPI_Init, whose
    shared-memory segments would exceed it."""
    scene, out = _small(tmp_path), tmp_path / "run"
    code = ("from mpi4py import MPI\nimport resource, sys\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))\n"
            "from pardem.cli import main\n"
            f"sys.exit(main(['run', {str(scene)!r}, '--out', {str(out)!r}, '--end', '0.3', "
            "'--quiet']))\n")
    env = dict(os.environ, NUMBA_NUM_THREADS="1", PYTHONPATH=str(Path(__file__).parents[2]))
    # compiled first without the limit: numba's cache files would exceed it
    warm = subprocess.run([mpiexec(), "-n", "2", sys.executable, "-c", code.replace(
        "resource.setrlimit", "(lambda *a: None)").replace("'0.3'", "'0.001'").replace(
        repr(str(out)), repr(str(tmp_path / "warm")))], env=env, capture_output=True, timeout=600)
    assert warm.returncode == 0, warm.stderr
    done = subprocess.run([mpiexec(), "-n", "2", sys.executable, "-c", code],
                          capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 4, done.stderr
    assert "File too large (" in done.stderr and f"while writing {out}/snapshots/" in done.stderr
    assert "Traceback" not in done.stderr


def _free(tmp_path, **extra):
    return {"scene": {"kind": "free", "name": "x"}, **extra}


def test_messages_show_values_as_the_user_wrote_them(tmp_path):
    """[ROBUST] L4: no numpy reprs, no 'gaps of inf m', a ring as wide as the gap accepted,
    files that are folders or devices named as such, a CSV with a byte-order mark and a
    comment line read."""
    same = [{"x": 0.0, "y": 0.0, "diameter": 7e-3, "mass": 3e-4}] * 2
    with pytest.raises(SceneError) as e:
        scene_from_dict(_free(tmp_path, particles=same))
    assert "identical positions (0.0, 0.0)" in str(e.value) and "np." not in str(e.value)
    one = {"scene": {"kind": "couette", "name": "x"},
           "geometry": {**SMALL, "inner_wall_count": 1, "inner_flat_surface": False},
           "species": [{"name": "s", "diameter": 7.42e-3, "mass": 2.75e-4, "count": 100}]}
    with pytest.raises(SceneError) as e:
        scene_from_dict(one)
    assert "single wall disk" in str(e.value) and "inf" not in str(e.value)
    ring = {"scene": {"kind": "couette", "name": "x"}, "geometry": SMALL,
            "species": [{"name": "s", "diameter": 7.42e-3, "mass": 2.75e-4, "count": 100}],
            "averaging": {"start": 0.0, "end": 1.0, "ring_width": 0.04}}
    assert scene_from_dict(ring).averaging.ring_width == 0.04  # 0.09 - 0.05 < 0.04 in floats
    for name, what in ((".", "is a folder"), ("/dev/zero", "is not a regular file")):
        with pytest.raises(SceneError, match=what):
            scene_from_dict(_free(tmp_path, particles_file=name), base_dir=tmp_path)
    csv = tmp_path / "p.csv"
    csv.write_text("\ufeffx,y,vx,vy,omega,diameter,mass\n# two disks\n"
                   "-0.01,0,0,0,0,0.00742,0.000275\n0.01,0,0,0,0,0.00742,0.000275\n",
                   encoding="utf-8")
    p = scene_from_dict(_free(tmp_path, particles_file="p.csv"), base_dir=tmp_path).particles
    assert p.x.tolist() == [-0.01, 0.01]


def test_plot_of_rings_without_any_torque_resistance(compressed_only, tmp_path):
    """Fig. 1.9 on a log axis with no finite positive mu_c (a short run with eta averages
    raised ValueError at saving): drawn on a linear axis with a note instead."""
    import numpy as np

    from averaging.plots import torque_resistance
    from averaging.report import load_run

    run = load_run(compressed_only)
    run["rings"]["mu_c"] = np.full_like(run["rings"]["mu_c"], np.nan)
    run["rings"]["kappa_zr"] = np.full_like(run["rings"]["kappa_zr"], np.nan)
    assert torque_resistance([run], tmp_path).exists()

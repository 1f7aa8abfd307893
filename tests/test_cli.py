"""The command line: a short run writes its files; bad input fails with one clear message."""

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import analytic_collision

import pardem
from pardem.cli import main
from pardem.core.timestep import resolve_dt

SCENES = Path(__file__).parent / "scenes"
SHIPPED = Path(__file__).parents[1] / "run_scripts" / "scenes"


def test_run_writes_snapshots_checkpoint_and_resolved_scene(tmp_path, capsys):
    assert main(["run", str(SCENES / "two_small.toml"), "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "steps/s" in err and "ETA" in err and "max overlap" in err and "E_kin" in err
    # stderr is not a terminal here: plain lines, as a batch job's log shows them
    assert "\r" not in err
    assert all(line.startswith("t = ") for line in err.splitlines() if "ETA" in line)
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
    # the collision happened: velocities reversed and reduced by the analytic e_n (0.2223; the
    # collision tests allow 5 % at this dt)
    _, e_n = analytic_collision(0.5 * scene.particles.mass[0])
    np.testing.assert_allclose(snaps[-1]["velocity"][:, 0], [-0.05 * e_n, 0.05 * e_n], rtol=0.05)
    log = (tmp_path / "log.txt").read_text().splitlines()
    assert f"run {scene.info.name}: t = 0 s to {scene.time.end:g} s, 2 particles" in log[0]
    assert any("steps/s" in line and "max overlap" in line for line in log)
    stage = next(k for k, line in enumerate(log) if "time per stage" in line)
    assert any("forces+integration" in line for line in log[stage:])


def test_snapshot_contacts_balance_particle_forces(tmp_path):
    """During the collision, the contact table's force is the particles' forces: -f on one,
    +f on the other (Newton's third law, exactly), and the table's normal + tangential force
    equals the particle force up to the damping of the half-step velocity change (the table
    is evaluated with synchronous velocities, the step with predicted ones)."""
    main(["run", str(SCENES / "two_small.toml"), "--out", str(tmp_path), "--quiet"])
    scene = pardem.load_scene(tmp_path / "scene.toml")
    dt, m_red = resolve_dt(scene), 0.5 * scene.particles.mass[0]
    touching = [s for s in pardem.read_snapshots(tmp_path) if s["contacts"]["ids"].shape[0]]
    assert len(touching) >= 2, "no snapshot caught the collision"
    for s in touching:
        c = s["contacts"]
        np.testing.assert_array_equal(c["ids"], [[0, 1]])
        assert c["overlap"][0] > 0
        np.testing.assert_array_equal(s["coordination"], [1, 1])
        f = s["force"]
        np.testing.assert_array_equal(f[0], -f[1])
        table = c["normal_force"][0] * c["normal"][0] + c["tangential_force"][0]
        # the relative velocity changes by dt/2 |f| / m_red over half a step: the slack is
        # gamma_n dt / (2 m_red) = 3 % of |f| here
        slack = scene.contact.gamma_n * 0.5 * dt * np.linalg.norm(f[0]) / m_red
        assert np.linalg.norm(table - f[0]) <= 1.01 * slack + 1e-12


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
    """Two stages refuse a crowded cell, each naming the scene file: the counts (more disk
    area than the cell has, when the file is read), and the placement (B's counts fit the cell
    at 0.81, but not on the start lattice, spaced by the largest diameter, without the dilute
    start)."""
    scene = (SHIPPED / "couette_quick.toml").read_text()
    bad = tmp_path / "crowded.toml"
    bad.write_text(scene.replace("count = 2545", "count = 25450"))
    assert main(["run", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"pardem: error: {bad}: [[species]] count: 25844 disks" in err
    # (25450 x 4.32412e-5 + 394 x 6.34761e-5) m^2 / 0.166643 m^2
    assert "fill 6.7540 of the cell" in err and "reduce the counts or enlarge outer_radius" in err
    bad.write_text(scene.replace("outer_start_radius = 0.33", "outer_start_radius = 0.2525"))
    assert main(["run", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"pardem: error: {bad}: cannot place 2939 particles" in err
    assert "outer_start_radius" in err


def test_a_scene_too_large_for_the_memory_is_refused_before_allocating(tmp_path, capsys,
                                                                        monkeypatch):
    """10^9 disks in a cell wide enough for them (62 m to 300 m rings) pass every check of the
    file; at ~600 B per particle they need ~559 GiB per rank. Refused before the placement
    allocates anything (without the check numpy raises MemoryError there), on a node that has
    64 GiB available."""
    import pardem.core.memory
    from helpers import couette_scene

    from pardem.input.scene_file import write_scene

    monkeypatch.setattr(pardem.core.memory, "available_bytes", lambda: 64.0 * 2**30)
    scene = couette_scene(counts=(10**9, 0), geometry={
        "inner_radius": 62.0, "outer_radius": 300.0, "outer_start_radius": 320.0,
        "compression_time": 100.0, "omega_inner": 1e-3, "inner_wall_count": 8000,
        "outer_wall_count": 8000})
    path = tmp_path / "huge.toml"
    write_scene(scene, path)
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"pardem: error: {path}: this run needs about 559 GiB per rank" in err
    assert "1000016000 particles with the wall disks" in err  # (1,000,016,000 x 600 B + 200 MB) / 2^30 = 559.0
    assert "only 64 GiB per rank is available" in err
    assert main(["check", str(path)]) == 0
    assert "# memory: about 559 GiB per rank" in capsys.readouterr().out


def test_a_folder_holding_another_run_needs_overwrite(tmp_path, capsys):
    """A new run never mixes its files with another run's: refused without --overwrite, which
    replaces that run (no snapshot of the old run is left); a restart of the same scene into
    its own folder continues it, and --restart accepts the run folder."""
    scene, out = str(SCENES / "two_small.toml"), str(tmp_path / "run")
    assert main(["run", scene, "--out", out, "--end", "0.02", "--quiet"]) == 0
    before = [s["time"] for s in pardem.read_snapshots(out)]
    capsys.readouterr()
    assert main(["run", scene, "--out", out, "--end", "0.01", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "holds another run" in err and "snapshots" in err and "--overwrite" in err
    assert [s["time"] for s in pardem.read_snapshots(out)] == before  # untouched
    assert main(["run", scene, "--out", out, "--end", "0.01", "--quiet", "--overwrite"]) == 0
    after = [s["time"] for s in pardem.read_snapshots(out)]
    assert after[-1] == pytest.approx(0.01, abs=1e-4) and len(after) < len(before)
    assert main(["run", scene, "--out", out, "--end", "0.02", "--quiet", "--restart", out]) == 0
    assert [s["time"] for s in pardem.read_snapshots(out)][-1] == pytest.approx(0.02, abs=1e-4)


def test_restart_from_a_folder_without_checkpoint_is_refused(tmp_path, capsys):
    assert main(["run", str(SCENES / "two_small.toml"), "--out", str(tmp_path / "o"),
                 "--restart", str(tmp_path)]) == 2
    assert f"--restart {tmp_path}: a folder without checkpoint.h5" in capsys.readouterr().err


def test_warmup_runs_every_writer_of_a_scene(capsys):
    """pardem warmup compiles what a run of the scene needs (the kernels, the output, the
    ring averages) in a scratch folder and says how long it took."""
    scene = Path(__file__).parents[1] / "examples" / "small_dilute.toml"
    assert main(["warmup", str(scene)]) == 0
    out, err = capsys.readouterr()
    assert "small_dilute.toml: kernels ready in" in out and "note" not in err


@pytest.mark.parametrize("args,message", [
    (["run", "s.toml", "--end", "nan"], "argument --end: nan: expected a finite time in seconds"),
    (["run", "s.toml", "--end", "inf"], "argument --end: inf: expected a finite time in seconds"),
    (["run", "s.toml", "--end", "-1"], "argument --end: -1: expected a finite time in seconds"),
    (["average", "d", "--start=-inf"], "argument --start: -inf: expected a finite time"),
    (["average", "d", "--ring-width", "0"],
     "argument --ring-width: 0: expected a finite length in metres, > 0"),
    (["average", "d", "--ring-width=-1e-3"], "argument --ring-width: -1e-3: expected a finite"),
    (["average", "d", "--ring-width", "nan"], "argument --ring-width: nan: expected a finite"),
    (["average", "d", "--ring-width", "inf"], "argument --ring-width: inf: expected a finite"),
])
def test_nonsense_times_and_widths_on_the_command_line_are_refused(args, message, capsys):
    """One usage line and exit status 2, before anything is read or run."""
    with pytest.raises(SystemExit) as stop:
        main(args)
    assert stop.value.code == 2
    assert message in capsys.readouterr().err


def test_a_ring_width_for_more_rings_than_allowed_is_refused_offline(tmp_path, capsys):
    """pardem average --ring-width 1e-12 names the ring count instead of allocating TiB."""
    scene = (SHIPPED / "couette_quick.toml").read_text()
    (tmp_path / "scene.toml").write_text(scene)
    assert main(["average", str(tmp_path), "--ring-width", "1e-12"]) == 2
    err = capsys.readouterr().err
    assert "ring width 1e-12 m: 1.49e+11 rings across the gap of 0.149 m; at most 100000" in err


def test_check_prints_the_step_and_the_stability_limit(capsys):
    """pardem check on the paper's B: dt = 10 ms / 230, the 10 ms quantum over the fewest
    steps no longer than t_c/50 (t_c = 2.17654 ms: 229.76 such steps), and the limit set by
    the damped translation of the densest packing, t_c/11.1 (tests/test_scene.py derives
    0.19630 ms)."""
    assert main(["check", str(SHIPPED / "couette_B.toml")]) == 0
    out = capsys.readouterr().out
    assert "dt = 4.34783e-05 s = t_c / 50.06" in out
    assert "output at exactly the times named" in out
    assert ("# stability limit dt <= 0.0001962 s = t_c / 11.1 (set by the densest packing's "
            "translation") in out
    assert "dt is 4.51 x below it" in out


def test_average_and_plot_of_damaged_output_files_say_so_in_one_line(tmp_path, capsys):
    """Output files that are not HDF5, or HDF5 without pardem's layout: exit 2 and one line
    naming the folder, no traceback."""
    import h5py

    scene = (SHIPPED / "couette_quick.toml").read_text()
    (tmp_path / "scene.toml").write_text(scene)
    (tmp_path / "snapshots").mkdir()
    (tmp_path / "snapshots" / "000000.h5").write_text("not HDF5")
    (tmp_path / "rings.h5").write_text("not HDF5")
    for command in (["average", str(tmp_path)], ["plot", str(tmp_path)]):
        assert main(command) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"pardem: error: {tmp_path}: its output files cannot be read (")
        assert len(err.splitlines()) == 1 and "Traceback" not in err
    (tmp_path / "snapshots" / "000000.h5").unlink()
    with h5py.File(tmp_path / "snapshots" / "000001.h5", "w") as f:
        f.attrs["format"] = "pardem-snapshot"  # a snapshot without its time and arrays
    assert main(["average", str(tmp_path)]) == 2
    assert "its output files cannot be read" in capsys.readouterr().err


def test_a_signal_is_recorded_only_inside_the_run_and_forgotten_after():
    """pardem run records SIGINT instead of raising (every rank then stops at one step); after
    the run the previous handler is back and the record is cleared, so a later run in the same
    process (a test, a notebook) is not stopped by an old signal."""
    import os
    import signal

    from pardem import stop

    before = signal.getsignal(signal.SIGINT)
    with stop.catching_signals():
        os.kill(os.getpid(), signal.SIGINT)
        assert stop.requested() == signal.SIGINT
    assert stop.requested() == 0
    assert signal.getsignal(signal.SIGINT) is before


def test_pardem_run_ignores_signals_after_its_run():
    """``pardem run`` (restore=False) leaves SIGINT and SIGTERM ignored after the run: Python
    would reset its own handlers to the default (death) at finalisation, before MPI_Finalize
    waits for the other ranks, while an ignored signal stays ignored (the end-to-end check is
    run_scripts/tools/kill_loop.py --signal INT on 2 ranks)."""
    import signal

    from pardem import stop

    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        with stop.catching_signals(restore=False):
            pass
        assert all(signal.getsignal(s) == signal.SIG_IGN for s in before)
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)


def test_a_full_disk_is_one_line_and_exit_4(tmp_path, capsys, monkeypatch):
    """No space left while writing a checkpoint: one line naming the file and the last complete
    checkpoint (each is written under a temporary name first), exit status 4, no traceback."""
    import errno

    import pardem.output.run_output

    def full(path, *args):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(pardem.output.run_output, "save_checkpoint", full)
    out = tmp_path / "run"
    assert main(["run", str(SCENES / "two_small.toml"), "--out", str(out), "--end", "0.02",
                 "--quiet"]) == 4
    err = capsys.readouterr().err
    assert (f"pardem: error: rank 0: No space left on device while writing {out}/checkpoint.h5;"
            " no checkpoint was written yet: free space") in err  # the first one failed
    assert "Traceback" not in err and f"continue with --restart {out}" in err

"""SIGINT and SIGTERM, repeated, to a serial run or to one rank of a parallel one: every rank
stops at the same step within seconds, the writers close (the final checkpoint holds that
state), the exit status is 128 + the signal's number, no traceback, no hang; the run continues
from its folder."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest
from helpers import couette_scene
from mpi_helpers import mpiexec

from pardem.input.scene_file import write_scene

CELL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
        "compression_time": 0.1, "omega_inner": 3.0}
ENV = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")


def ranks_of(out: Path) -> list[int]:
    """Pids of the Python processes of a run writing into ``out`` (its ranks), ascending."""
    pids = []
    for entry in Path("/proc").iterdir():
        try:
            cmd = (entry / "cmdline").read_bytes().split(b"\0")
        except (OSError, ValueError):
            continue
        if cmd and cmd[0] == sys.executable.encode() and str(out).encode() in cmd:
            pids.append(int(entry.name))
    return sorted(pids)


def start(tmp_path, name: str, ranks: int):
    scene = tmp_path / f"{name}.toml"
    write_scene(couette_scene(counts=(260, 40), geometry=CELL, name=name,
                              output={"checkpoint_interval": 0.05}), scene)
    out = tmp_path / name
    cmd = [sys.executable, "-m", "pardem.cli", "run", str(scene), "--out", str(out), "--end",
           "60", "--quiet"]
    if ranks > 1:
        cmd = [mpiexec(), "-n", str(ranks), *cmd]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env=ENV, start_new_session=True)
    deadline = time.time() + 600  # a cold numba cache compiles first
    while not (out / "checkpoint.h5").exists():
        assert proc.poll() is None and time.time() < deadline, proc.stderr.read()
        time.sleep(0.05)
    time.sleep(0.3)
    return scene, out, proc


def stopped(proc, timeout: float = 30.0) -> tuple[int, str]:
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise AssertionError(f"no exit within {timeout} s of the signals: a hang") from None
    return proc.returncode, err


def check_stopped(code: int, err: str, sig, out: Path, scene: Path, ranks: int) -> None:
    assert code == 128 + sig, err
    assert f"stopped by {sig.name} at t = " in err and "Traceback" not in err, err
    assert f"continue with --restart {out}" in err
    with h5py.File(out / "checkpoint.h5") as h5:
        t, n = float(h5.attrs["time"]), int(h5.attrs["ranks"])
    assert n == ranks and f"at t = {t:.6g} s" in err  # the checkpoint holds the stopped state
    again = subprocess.run([sys.executable, "-m", "pardem.cli", "run", str(scene), "--out",
                            str(out), "--restart", str(out), "--end", f"{t + 0.02}", "--quiet"],
                           capture_output=True, text=True, env=ENV, timeout=600)
    assert again.returncode == 0, again.stderr


@pytest.mark.parametrize("sig,repeats", [(signal.SIGINT, 2), (signal.SIGTERM, 1),
                                         (signal.SIGINT, 5)])
def test_signals_to_a_serial_run(tmp_path, sig, repeats):
    scene, out, proc = start(tmp_path, "serial", 1)
    for _ in range(repeats):
        os.kill(proc.pid, sig)
        time.sleep(0.002)
    code, err = stopped(proc)
    check_stopped(code, err, sig, out, scene, 1)


@pytest.mark.parametrize("which", [0, 1])
def test_repeated_sigint_to_one_rank_stops_every_rank(tmp_path, which):
    """Two SIGINTs 2 ms apart to one rank only (the case that hung mpiexec before: the second
    interrupt landed in the error handler, before MPI_Abort)."""
    scene, out, proc = start(tmp_path, f"two{which}", 2)
    pids = ranks_of(out)
    assert len(pids) == 2, pids
    for _ in range(2):
        os.kill(pids[which], signal.SIGINT)
        time.sleep(0.002)
    code, err = stopped(proc)
    check_stopped(code, err, signal.SIGINT, out, scene, 2)


@pytest.mark.parametrize("ranks,which", [(1, 0), (2, 1)])
def test_sigint_during_set_up_is_one_line_and_no_hang(tmp_path, ranks, which):
    """Ctrl-C before the time-step loop (reading the scene, building the state, compiling):
    Python's KeyboardInterrupt, turned into one line and exit 130 by the rank that got it; a
    parallel job ends on every rank instead of waiting in set-up's collectives. The kernels are
    cached, so the set-up lasts ~0.4 s: the signal goes out as soon as the first line is read,
    to the process itself on one rank (finding the ranks of a parallel job takes a scan of
    /proc)."""
    scene = tmp_path / "setup.toml"
    write_scene(couette_scene(counts=(260, 40), geometry=CELL, name="setup"), scene)
    launch = [mpiexec(), "-n", str(ranks)] if ranks > 1 else []
    subprocess.run([*launch, sys.executable, "-m", "pardem.cli", "warmup", str(scene)],
                   env=ENV, check=True, capture_output=True, timeout=600)  # the kernels cached
    cmd = [*launch, sys.executable, "-m", "pardem.cli", "run", str(scene), "--out",
           str(tmp_path / "o"), "--end", "60", "--quiet"]  # a late signal would stop the run
    # SIGINT's default disposition, as from a terminal: a job started in the background by a
    # non-interactive shell inherits SIGINT ignored, and Python keeps it so until pardem's own
    # handlers take over at the time-step loop
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env=ENV, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    first = proc.stderr.readline()  # written after the scene is read, before the set-up
    pids = [proc.pid] if ranks == 1 else ranks_of(tmp_path / "o")
    assert "building the initial state" in first, first
    assert len(pids) == ranks, pids
    os.kill(pids[which], signal.SIGINT)
    code, err = stopped(proc)
    assert code == 130 if ranks == 1 else code != 0, err
    assert "interrupted (SIGINT) outside the time-step loop" in err, err
    assert "Traceback" not in err, err

"""Launching MPI runs from the serial test suite (see ../shared/notes/toolchain.md §6).

Always the ``mpiexec`` beside ``sys.executable`` (the mpich wheel that mpi4py uses), always
``python -m mpi4py`` (an uncaught exception aborts every rank) and always a timeout.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np

MPI_DIR = Path(__file__).parent / "mpi"


def mpiexec() -> str:
    return str(Path(sys.executable).parent / "mpiexec")


def run_mpi(args: list[str], n: int, timeout: float = 600, check: bool = True,
            module: bool = True, env: dict | None = None) -> subprocess.CompletedProcess:
    """Run ``python [-m mpi4py] ARGS`` on n ranks (``env``: extra environment variables); fail
    the test on a non-zero exit or timeout."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1", **(env or {}))
    py = [sys.executable, "-m", "mpi4py"] if module else [sys.executable]
    # a session of its own, so that a timeout kills the ranks and proxies too, not just mpiexec
    with subprocess.Popen([mpiexec(), "-n", str(n), *py, *args], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, env=env,
                          start_new_session=True) as proc:
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, err = proc.communicate()
            raise AssertionError(f"MPI run on {n} ranks timed out after {timeout} s "
                                 f"(deadlock?)\n{err}") from None
    done = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
    if check and done.returncode != 0:
        raise AssertionError(f"MPI run on {n} ranks failed ({done.returncode}):\n{err}")
    return done


def dump_state(scene: Path, steps: int, out: Path, n: int, *extra: str,
               env: dict | None = None, timeout: float = 600) -> dict:
    """Run tests/mpi/dump_state.py on n ranks; return the saved arrays."""
    run_mpi([str(MPI_DIR / "dump_state.py"), str(scene), str(steps), str(out), *extra], n,
            env=env, timeout=timeout)
    with np.load(out) as f:
        return {k: f[k] for k in f.files}


STATE = ("gid", "x", "v", "theta", "omega", "f", "tau", "hist_wall", "pair_lo", "pair_hi",
         "pair_hist", "step")


def assert_same_state(a: dict, b: dict, label: str) -> None:
    """Bitwise equality of every state array (particles sorted by gid, springs by key)."""
    for k in STATE:
        assert a[k].shape == b[k].shape, f"{label}: {k} shapes {a[k].shape} != {b[k].shape}"
        same = np.array_equal(a[k], b[k])
        assert same, f"{label}: {k} differs in {int(np.sum(a[k] != b[k]))} entries"

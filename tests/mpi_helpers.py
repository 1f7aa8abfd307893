"""Launching MPI runs from the serial test suite (see ../shared/notes/toolchain.md §6).

Always the ``mpiexec`` beside ``sys.executable`` (the mpich wheel that mpi4py uses), always
``python -m mpi4py`` (an uncaught exception aborts every rank) and always a timeout.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

MPI_DIR = Path(__file__).parent / "mpi"


def mpiexec() -> str:
    return str(Path(sys.executable).parent / "mpiexec")


def run_mpi(args: list[str], n: int, timeout: float = 120, check: bool = True,
            module: bool = True, env: dict | None = None) -> subprocess.CompletedProcess:
    """Run ``python [-m mpi4py] ARGS`` on n ranks (``env``: extra environment variables); fail
    the test on a non-zero exit or timeout."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1", **(env or {}))
    py = [sys.executable, "-m", "mpi4py"] if module else [sys.executable]
    try:
        proc = subprocess.run([mpiexec(), "-n", str(n), *py, *args], capture_output=True,
                              text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired as e:
        raise AssertionError(f"MPI run on {n} ranks timed out (deadlock?)\n{e.stderr}") from e
    if check and proc.returncode != 0:
        raise AssertionError(f"MPI run on {n} ranks failed ({proc.returncode}):\n{proc.stderr}")
    return proc


def dump_state(scene: Path, steps: int, out: Path, n: int, *extra: str,
               env: dict | None = None) -> dict:
    """Run tests/mpi/dump_state.py on n ranks; return the saved arrays."""
    run_mpi([str(MPI_DIR / "dump_state.py"), str(scene), str(steps), str(out), *extra], n,
            env=env)
    with np.load(out) as f:
        return {k: f[k] for k in f.files}


STATE = ("gid", "x", "v", "theta", "omega", "f", "tau", "xi_wall", "pair_lo", "pair_hi",
         "pair_xi", "step")


def assert_same_state(a: dict, b: dict, label: str) -> None:
    """Bitwise equality of every state array (particles sorted by gid, springs by key)."""
    for k in STATE:
        assert a[k].shape == b[k].shape, f"{label}: {k} shapes {a[k].shape} != {b[k].shape}"
        same = np.array_equal(a[k], b[k])
        assert same, f"{label}: {k} differs in {int(np.sum(a[k] != b[k]))} entries"

"""What the benchmarks that compare two commits share: an older revision checked out beside
this tree, and MPI jobs that run a script's worker on a given tree and report one JSON line.

    with checkout(rev) as old: ...                 # None without a revision
    result = mpi_job(tree, ranks, [script, "--worker", ...], env)   # worker calls emit(obj)
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MARK = "RESULT "


@contextlib.contextmanager
def checkout(rev: str | None):
    """A temporary git worktree of ``rev`` (its path), removed afterwards; None without one."""
    if rev is None:
        yield None
        return
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp) / "old"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "-q", "--detach", str(tree),
                        rev], check=True, capture_output=True)
        try:
            yield tree
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                           capture_output=True)


def emit(result: dict) -> None:
    """The worker's report (rank 0): one line that ``mpi_job`` picks out of the output."""
    print(MARK + json.dumps(result), flush=True)


def mpi_job(tree: Path, ranks: int, argv: list[str], env: dict | None = None) -> dict:
    """Run ``python ARGV`` under ``mpiexec -n RANKS`` with the pardem of ``tree`` (one core per
    rank) and return what its worker emitted; exit with the job's output if it emitted nothing."""
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_NUM_THREADS="1", **(env or {}))
    cmd = [str(Path(sys.executable).parent / "mpiexec"), "-n", str(ranks), sys.executable,
           *argv]
    done = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    for line in done.stdout.splitlines():
        if line.startswith(MARK):
            return json.loads(line[len(MARK):])
    raise SystemExit(f"job failed ({' '.join(cmd)}):\n{done.stdout}\n{done.stderr}")

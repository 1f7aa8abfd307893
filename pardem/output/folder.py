"""The output folder of a run: a new run does not write over another run's files unless asked.

Stage: output (rank 0). A folder "holds a run" when it has any of ``RUN_FILES``. A restart
into a folder that holds the same scene's run continues it (snapshots after the checkpoint
are replaced); anything else needs ``overwrite`` (``pardem run --overwrite``), which removes
those files first, so that old and new files never mix. ``--overwrite`` removes only what
pardem wrote: the names a run claimed are recorded in ``DIR/.pardem-files`` (``MANIFEST``),
and a file of one of those names that pardem did not write (a user's own scene.toml in
``--out .``, a symlink, a mount point) stops the run instead of being deleted. While a job claims the folder or
writes into it, it holds ``FolderLock`` (an flock on ``DIR/.pardem-lock``, released by the
kernel however the job ends, kill -9 included): a second job is refused, naming the first.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import socket
import time
from pathlib import Path

from ..input.scene import SceneError
from ..input.scene_file import load_scene

RUN_FILES = ("scene.toml", "log.txt", "checkpoint.h5", "snapshots", "particles.xdmf",
             "contacts.xdmf", "rings.h5", "rings.csv", "rings_blocks.csv", "ring_loads.csv",
             "rings.vtu", "particles.h5")  # the snapshots of earlier pardem versions


LOCK = ".pardem-lock"
MANIFEST = ".pardem-files"
LEGACY_SIGNS = ("checkpoint.h5", "snapshots", "particles.h5")
"""A folder without a manifest counts as an earlier pardem version's run folder when it holds
one of these (no user makes them by hand) or a scene.toml that pardem wrote."""


class FolderLock:
    """An exclusive lock on a run folder, held from ``acquire`` to ``release`` (or the end of
    the process). SceneError, naming the holder, if another job holds it."""

    def __init__(self, out_dir: Path):
        self.path = Path(out_dir) / LOCK
        self.fd: int | None = None

    def acquire(self) -> None:
        if self.fd is not None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"pardem job {os.getpid()} on {socket.gethostname()}, since "
                          f"{time.strftime('%Y-%m-%d %H:%M:%S')}".encode(), 0)
        except BlockingIOError:
            holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "another job"
            os.close(fd)
            raise SceneError(f"--out {self.path.parent}: the folder is in use by {holder}; wait "
                             "for that job to end, or choose another folder") from None
        except BaseException:
            os.close(fd)
            raise
        self.fd = fd

    def release(self) -> None:
        if self.fd is not None:
            os.close(self.fd)  # closing the descriptor drops the flock
            self.fd = None


def run_files(out_dir: Path) -> set[str]:
    """The run files in ``out_dir`` now."""
    return {name for name in RUN_FILES if os.path.lexists(out_dir / name)}


def written_by_pardem(out_dir: Path, present: set[str]) -> set[str]:
    """Those of ``present`` that a pardem run wrote: the names of the folder's manifest, or
    every run file of an earlier version's run folder (LEGACY_SIGNS); never a symlink or a
    mount point, which pardem does not make."""
    manifest = out_dir / MANIFEST
    if manifest.is_file():
        ours = set(manifest.read_text(encoding="utf-8", errors="replace").split())
    elif any(name in present for name in LEGACY_SIGNS) or _pardem_scene(out_dir / "scene.toml"):
        ours = set(RUN_FILES)
    else:
        ours = set()
    return {name for name in present & ours
            if not (out_dir / name).is_symlink() and not os.path.ismount(out_dir / name)}


def _pardem_scene(path: Path) -> bool:
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.readline().startswith("# pardem scene")
    except OSError:
        return False


def record_claim(out_dir: Path) -> None:
    """Write the manifest: every name a run in ``out_dir`` may write (atomically)."""
    if (out_dir / MANIFEST).is_dir():
        raise SceneError(f"--out {out_dir}: {MANIFEST} is a folder; pardem keeps the names of "
                         "a run's files in a file of that name: remove or rename the folder")
    tmp = out_dir / (MANIFEST + ".tmp")
    tmp.write_text("\n".join(RUN_FILES) + "\n", encoding="utf-8")
    os.replace(tmp, out_dir / MANIFEST)


def lock_unchanged(out_dir: Path, lock: FolderLock, claimed: set[str]) -> None:
    """Take ``lock`` for writing, once the folder is known to hold no run files but the
    ``claimed`` ones (those present when this job claimed it): another job may have claimed the
    same empty folder and written into it while this one was still compiling."""
    lock.acquire()
    new = run_files(out_dir) - claimed - {"log.txt"}  # this job logs before it runs
    if new:
        lock.release()
        raise SceneError(f"--out {out_dir}: another job wrote {', '.join(sorted(new))} into the "
                         "folder after this one claimed it; choose another folder")


def claim(out_dir: Path, decomp, scene, restart, overwrite: bool, lock: FolderLock,
          log) -> set[str]:
    """claim_folder on rank 0 for every rank, under ``lock`` (released on return); logs what
    --overwrite removed. Returns the run files then present."""
    try:
        removed = decomp.bcast_call(claim_folder, out_dir, scene, restart, overwrite, lock)
        claimed = decomp.bcast_call(run_files, out_dir)
    finally:
        lock.release()
    if removed:
        log(f"--overwrite: removed the previous run's {', '.join(removed)}")
    return claimed


def claim_folder(out_dir: Path, scene, restart, overwrite: bool, lock: FolderLock) -> list[str]:
    """Make ``out_dir`` ready for a run of ``scene`` (continuing from ``restart``, a
    checkpoint path or None), under ``lock`` (held on return). Returns the files removed
    (``overwrite``); SceneError if another job holds the folder, or if it holds another run and
    ``overwrite`` is false."""
    lock.acquire()
    present = run_files(out_dir)
    found = [name for name in RUN_FILES if name in present]
    foreign = sorted(present - written_by_pardem(out_dir, present))
    if foreign:
        raise SceneError(f"--out {out_dir}: {', '.join(foreign)} not written by pardem (a run "
                         f"records its files in {MANIFEST}); pardem writes files of these "
                         "names: move them, or choose another folder")
    if not found:
        record_claim(out_dir)
        return []
    if restart is not None and not overwrite and _same_scene(out_dir / "scene.toml", scene):
        record_claim(out_dir)
        return []
    if not overwrite:
        what = ("a run of another scene" if (out_dir / "scene.toml").exists()
                and restart is not None else "another run")
        raise SceneError(f"--out {out_dir}: the folder holds {what} ({', '.join(found)}); "
                         "choose another folder, or pass --overwrite to replace that run "
                         "(Python: Simulation(..., overwrite=True))")
    keep = None
    if restart is not None:  # a checkpoint file, or a run folder with one
        keep = Path(restart) / "checkpoint.h5" if Path(restart).is_dir() else Path(restart)
        keep = keep.resolve()
    removed = []
    for name in sorted(found, key=lambda n: not n.endswith(".xdmf")):  # indexes first: a
        path = out_dir / name  # kill in between never leaves one naming deleted snapshots
        if path.resolve() != keep:  # the checkpoint being continued from stays
            shutil.rmtree(path) if path.is_dir() else path.unlink()
            removed.append(name)
    record_claim(out_dir)
    return removed


def _same_scene(path: Path, scene) -> bool:
    try:
        return load_scene(path).fingerprint() == scene.fingerprint()
    except (SceneError, OSError):
        return False

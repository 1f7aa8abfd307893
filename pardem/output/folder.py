"""The output folder of a run: a new run does not write over another run's files unless asked.

Stage: output (rank 0). A folder "holds a run" when it has any of ``RUN_FILES``. A restart
into a folder that holds the same scene's run continues it (snapshots after the checkpoint
are replaced); anything else needs ``overwrite`` (``pardem run --overwrite``), which removes
those files first, so that old and new files never mix.
"""

from __future__ import annotations

from pathlib import Path

from ..scene import SceneError, load_scene

RUN_FILES = ("scene.toml", "log.txt", "checkpoint.h5", "particles.h5", "particles.xdmf",
             "contacts.xdmf", "rings.h5", "rings.csv", "rings.vtu")


def claim_folder(out_dir: Path, scene, restart, overwrite: bool) -> list[str]:
    """Make ``out_dir`` ready for a run of ``scene`` (continuing from ``restart``, a
    checkpoint path or None). Returns the files removed (``overwrite``); SceneError if the
    folder holds another run and ``overwrite`` is false."""
    found = [name for name in RUN_FILES if (out_dir / name).exists()]
    if not found:
        return []
    if restart is not None and not overwrite and _same_scene(out_dir / "scene.toml", scene):
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
    for name in found:
        path = out_dir / name
        if path.resolve() != keep:  # the checkpoint being continued from stays
            path.unlink()
            removed.append(name)
    return removed


def _same_scene(path: Path, scene) -> bool:
    try:
        return load_scene(path).fingerprint() == scene.fingerprint()
    except (SceneError, OSError):
        return False

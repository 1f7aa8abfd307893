"""Checkpoints: the full state in one HDF5 file, written atomically.

Stage: output / restart. Holds every particle array (including forces and torques of the current
positions, which velocity Verlet needs for its next half kick), the tangential springs of all
listed pairs keyed by (gid_lo, gid_hi), the flat-ring springs, the step counter (time = step * dt),
the inner-ring angle, dt and the scene fingerprint (a restart of a different scene is refused).
The file is written as ``NAME.tmp`` and renamed, so a crash never leaves a broken checkpoint.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np

from ..scene import SceneError

ARRAYS = ("gid", "kind", "x", "v", "theta", "omega", "f", "tau", "radius", "mass", "phi0", "e0",
          "xi_wall")


def save_checkpoint(path: str | os.PathLike, arrays: dict[str, np.ndarray],
                    attrs: dict[str, object]) -> None:
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with h5py.File(tmp, "w") as h5:
        h5.attrs["format"] = "pardem-checkpoint"
        h5.attrs["version"] = 1
        for k, v in attrs.items():
            h5.attrs[k] = v
        for k, v in arrays.items():
            h5.create_dataset(k, data=v)
    os.replace(tmp, path)


def load_checkpoint(path: str | os.PathLike) -> tuple[dict[str, np.ndarray], dict[str, object]]:
    path = Path(path)
    if not path.exists():
        raise SceneError(f"--restart {path}: file does not exist")
    try:
        with h5py.File(path, "r") as h5:
            if h5.attrs.get("format") != "pardem-checkpoint":
                raise SceneError(f"--restart {path}: not a pardem checkpoint")
            attrs = dict(h5.attrs)
            arrays = {k: h5[k][()] for k in h5.keys()}
    except OSError as e:
        raise SceneError(f"--restart {path}: unreadable or truncated checkpoint ({e})") from e
    missing = [k for k in ARRAYS + ("pair_lo", "pair_hi", "pair_xi") if k not in arrays]
    if missing:
        raise SceneError(f"--restart {path}: checkpoint lacks {', '.join(missing)}")
    return arrays, attrs

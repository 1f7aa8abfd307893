"""Checkpoint files: the full state in one HDF5 file, written atomically.

Stage: output / restart (what goes in: ``restart.py``). Datasets: every particle array
(``ARRAYS``, including forces and torques of the current positions, which velocity Verlet needs
for its next half kick), the contact history keyed by (gid_lo, gid_hi) (``pair_lo``,
``pair_hi``, ``pair_hist``; columns named in the attribute ``history_columns``), the applied
forces of touching pairs (``force_lo``, ``force_hi``, ``pair_force`` [m,3]) and of ring
contacts (``ring_force`` [n,3]); attributes: the step (time = step * dt), time, dt, the
inner-ring angle (``ring_angle``) and its phase (``ring_phase``: 0 but in a branch that
changed omega_inner, ``branch.py``), the scene fingerprint (a restart of a different scene
is refused), whether the snapshot of this state is an end snapshot off the snapshot grid
(``end_snapshot``: a continued run replaces it, ``series.py``). With
in-situ averaging, the ring samples so far (``rings_sums``, ``rings_times``,
``rings_inner_torque``, ``rings_loads``; attribute ``rings_layout``: see ``averages.py``).
Version 1 files (pardem before the contact-model slots) are read too. The file is written as
``NAME.tmp`` and renamed, so a crash never leaves a broken checkpoint.
"""

from __future__ import annotations

import math
import os
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

from ..input.scene import SceneError
from .atomic import size_of, writing

ARRAYS = ("gid", "kind", "species", "x", "v", "theta", "omega", "f", "tau", "radius", "mass",
          "phi0", "e0", "hist_wall")
LATER_ARRAYS = ("species",)
"""Particle arrays a checkpoint of an older pardem may lack: read from the scene then (each
particle's species follows from the scene and its id, as its radius and mass do)."""
PAIRS = ("pair_lo", "pair_hi", "pair_hist", "force_lo", "force_hi", "pair_force", "ring_force")
VERSION = 2


def save_checkpoint(path: str | os.PathLike, arrays: dict[str, np.ndarray],
                    attrs: dict[str, object]) -> None:
    with writing(Path(path), size_of(arrays)) as tmp, h5py.File(tmp, "w") as h5:
        h5.attrs["format"] = "pardem-checkpoint"
        h5.attrs["version"] = VERSION
        for k, v in attrs.items():
            h5.attrs[k] = v
        for k, v in arrays.items():
            h5.create_dataset(k, data=v)


def checkpoint_file(path: str | os.PathLike) -> Path:
    """The checkpoint file ``path`` names: the file itself, or a run folder's checkpoint.h5."""
    path = Path(path)
    if path.is_dir():
        if not (path / "checkpoint.h5").is_file():
            raise SceneError(f"--restart {path}: a folder without checkpoint.h5")
        path = path / "checkpoint.h5"
    if not path.exists():
        raise SceneError(f"--restart {path}: file does not exist")
    return path


@contextmanager
def open_checkpoint(path: str | os.PathLike):
    """The checkpoint at ``path`` (a file or a run folder), open for reading and checked:
    yields ``(datasets, attrs)``, the datasets unread (h5py's, sliced for the rows wanted;
    a restart reads only its rank's share), attrs["history_columns"] as a tuple of names."""
    path = checkpoint_file(path)
    try:
        with h5py.File(path, "r") as h5:
            if h5.attrs.get("format") != "pardem-checkpoint":
                raise SceneError(f"--restart {path}: not a pardem checkpoint")
            attrs = dict(h5.attrs)
            groups = [k for k in h5.keys() if not isinstance(h5[k], h5py.Dataset)]
            if groups:
                raise SceneError(f"--restart {path}: corrupted checkpoint: {groups[0]!r} is a "
                                 "group, not a dataset")
            arrays = {k: h5[k] for k in h5.keys()}
            if int(attrs.get("version", 1)) == 1:
                _upgrade(arrays, attrs)
            missing = [k for k in ARRAYS + PAIRS if k not in arrays and k not in LATER_ARRAYS]
            missing += [f"attribute {a!r}" for a in ATTRS if a not in attrs]
            if missing:
                raise SceneError(f"--restart {path}: corrupted checkpoint: it lacks "
                                 f"{', '.join(missing)}")
            _check_layout(path, arrays, attrs)
            names = str(attrs.get("history_columns", ""))
            attrs["history_columns"] = tuple(names.split(",")) if names else ()
            yield arrays, attrs
    except (OSError, RuntimeError) as e:  # h5py: RuntimeError for a damaged link table
        raise SceneError(f"--restart {path}: unreadable or truncated checkpoint ({e})") from e


ATTRS = ("step", "time", "dt", "fingerprint")
# trailing shape of each dataset; rows: "n" per particle, "m" per history pair, "q" per force
LAYOUT = {"gid": ("n", ()), "kind": ("n", ()), "species": ("n", ()), "x": ("n", (2,)),
          "v": ("n", (2,)), "theta": ("n", ()), "omega": ("n", ()), "f": ("n", (2,)),
          "tau": ("n", ()), "radius": ("n", ()), "mass": ("n", ()), "phi0": ("n", ()),
          "e0": ("n", (2,)),
          "ring_force": ("n", (3,)), "pair_lo": ("m", ()), "pair_hi": ("m", ()),
          "force_lo": ("q", ()), "force_hi": ("q", ()), "pair_force": ("q", (3,))}


def _check_layout(path, arrays: dict[str, np.ndarray], attrs: dict[str, object]) -> None:
    """Every dataset numeric, of its documented shape and row count; the step a non-negative
    integer with time = step * dt (to rounding: the time is the exact step count times the
    step as a fraction, dt its float): a hand-edited or damaged file is refused by name."""
    for key in ("gid", "pair_lo", "force_lo"):  # the row counts come from these
        if np.ndim(arrays[key]) != 1:
            raise SceneError(f"--restart {path}: corrupted checkpoint: {key} has shape "
                             f"{np.shape(arrays[key])}, expected one row per entry")
    rows = {"n": np.shape(arrays["gid"]), "m": np.shape(arrays["pair_lo"]),
            "q": np.shape(arrays["force_lo"])}
    for key, (count, tail) in LAYOUT.items():
        if key in LATER_ARRAYS and key not in arrays:
            continue
        a = arrays[key]  # shape and dtype only: nothing is read
        want = rows[count] + tail
        if a.dtype.kind not in "iuf" or a.shape != want:
            raise SceneError(f"--restart {path}: corrupted checkpoint: {key} has shape "
                             f"{a.shape} of {a.dtype}, expected {want} of numbers")
    for key, count in (("pair_hist", "m"), ("hist_wall", "n")):
        a = arrays[key]
        if a.dtype.kind not in "iuf" or a.ndim != 2 or a.shape[0] not in (rows[count][0], 0):
            raise SceneError(f"--restart {path}: corrupted checkpoint: {key} has shape "
                             f"{a.shape} of {a.dtype}, expected ({rows[count][0]}, columns)")
    step, dt, time = attrs["step"], attrs["dt"], attrs["time"]
    if not (isinstance(step, (int, np.integer)) and step >= 0 and np.isfinite(dt) and dt > 0
            and math.isclose(time, step * dt, rel_tol=1e-12)):
        raise SceneError(f"--restart {path}: corrupted checkpoint: step {step}, dt {dt} s and "
                         f"time {time} s do not agree (time = step x dt, step >= 0)")


def _upgrade(arrays: dict[str, np.ndarray], attrs: dict[str, object]) -> None:
    """A version-1 checkpoint in version 2's terms: ``xi_wall``/``pair_xi`` hold the spring (2
    columns) or the spring and eta (4); no recorded forces (output at the restart step reports
    zero forces until the first step)."""
    for old, new in (("xi_wall", "hist_wall"), ("pair_xi", "pair_hist")):
        if old in arrays:
            arrays[new] = arrays.pop(old)
    width = arrays["pair_hist"].shape[1] if arrays.get("pair_hist") is not None else 0
    attrs["history_columns"] = {0: "", 2: "spring_x,spring_y",
                                4: "spring_x,spring_y,eta_x,eta_y"}.get(width, "")
    if not arrays["pair_hist"].size and not arrays["hist_wall"].size:
        attrs["history_columns"] = ""
    arrays.setdefault("force_lo", np.zeros(0, np.int64))
    arrays.setdefault("force_hi", np.zeros(0, np.int64))
    arrays.setdefault("pair_force", np.zeros((0, 3)))
    arrays.setdefault("ring_force", np.zeros((arrays["gid"].size, 3)))

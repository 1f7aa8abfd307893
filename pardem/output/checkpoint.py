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
(``end_snapshot``: a continued run replaces it, ``series.py``), a CRC-32 of every dataset's
bytes (``checksums``, JSON: a flipped bit is found before any value is used). With
in-situ averaging, the ring samples so far (``rings_sums``, ``rings_times``,
``rings_inner_torque``, ``rings_loads``; attribute ``rings_layout``: see ``averages.py``).
Version 1 files (pardem before the contact-model slots) are read too. The file is written as
``NAME.tmp`` and renamed, so a crash never leaves a broken checkpoint.

Reading (``open_checkpoint``) checks, in this order, before a caller sees any value: the
format, the version (a whole number this pardem reads: a later one is refused, not guessed
at), every attribute's type (the JSON ones parsed), every dataset's shape and type, then every
dataset read once in chunks against its checksum. A damaged or foreign file thus gives one
SceneError that names the file and what is wrong, never h5py's own exception.
"""

from __future__ import annotations

import json
import math
import os
import zlib
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
READS = (1, 2)
"""Checkpoint versions this pardem reads."""
DAMAGED = (OSError, RuntimeError, KeyError, ValueError, TypeError)
"""What h5py raises reading a damaged file (a bad link table, data past the end of the file,
a corrupted type or filter description)."""
VERIFY_ROWS = 1 << 18
"""Rows of a dataset read at a time to check it: no rank holds a large cell's file whole."""


def save_checkpoint(path: str | os.PathLike, arrays: dict[str, np.ndarray],
                    attrs: dict[str, object]) -> None:
    with writing(Path(path), size_of(arrays)) as tmp, h5py.File(tmp, "w") as h5:
        h5.attrs["format"] = "pardem-checkpoint"
        h5.attrs["version"] = VERSION
        for k, v in attrs.items():
            h5.attrs[k] = v
        for k, v in arrays.items():
            h5.create_dataset(k, data=v)
        h5.attrs["checksums"] = json.dumps({k: checksum(v) for k, v in arrays.items()},
                                           sort_keys=True)


def checksum(a: np.ndarray) -> int:
    """CRC-32 of an array's bytes in C order (as HDF5 stores a dataset written from it)."""
    return zlib.crc32(np.ascontiguousarray(a).view(np.uint8).reshape(-1))


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
def open_checkpoint(path: str | os.PathLike, verify: bool = True):
    """The checkpoint at ``path`` (a file or a run folder), open for reading and checked:
    yields ``(datasets, attrs)``, the datasets unread (h5py's, sliced for the rows wanted;
    a restart reads only its rank's share), attrs["history_columns"] as a tuple of names,
    attrs["scene_physics"] (if written) parsed. ``verify``: read every dataset once against
    its checksum first (False where the same file was just verified: a restart's ranks read
    their shares after rank 0 has checked it)."""
    path = checkpoint_file(path)
    try:
        with h5py.File(path, "r") as h5:
            try:
                arrays, attrs = _checked(path, h5, verify)
            except SceneError:  # the checks' own verdicts (a ValueError too) stand as said
                raise
            except (OSError, RuntimeError):  # said below, as for the file itself
                raise
            except DAMAGED as e:  # h5py on a damaged object header, type or link table
                raise SceneError(f"--restart {path}: corrupted checkpoint: it cannot be read "
                                 f"({str(e).strip(chr(39)) or type(e).__name__})") from e
            yield arrays, attrs
    except (OSError, RuntimeError) as e:  # h5py: RuntimeError for a damaged link table
        raise SceneError(f"--restart {path}: unreadable or truncated checkpoint ({e})") from e


def _checked(path, h5, verify: bool) -> tuple[dict, dict]:
    """``open_checkpoint``'s datasets and attributes, every check passed."""
    if h5.attrs.get("format") != "pardem-checkpoint":
        raise SceneError(f"--restart {path}: not a pardem checkpoint")
    attrs = dict(h5.attrs)
    version = _version(path, attrs.get("version", 1))
    groups = [k for k in h5.keys() if not isinstance(h5[k], h5py.Dataset)]
    if groups:
        raise SceneError(f"--restart {path}: corrupted checkpoint: {groups[0]!r} is a "
                         "group, not a dataset")
    arrays = {k: h5[k] for k in h5.keys()}
    if version == 1:
        _upgrade(arrays, attrs)
    missing = [k for k in ARRAYS + PAIRS if k not in arrays and k not in LATER_ARRAYS]
    missing += [f"attribute {a!r}" for a in ATTRS if a not in attrs]
    if missing:
        raise SceneError(f"--restart {path}: corrupted checkpoint: it lacks "
                         f"{', '.join(missing)}")
    _check_attrs(path, attrs)
    _check_layout(path, arrays, attrs)
    if verify:
        _verify(path, h5, attrs.get("checksums"))
    names = str(attrs.get("history_columns", ""))
    attrs["history_columns"] = tuple(names.split(",")) if names else ()
    return arrays, attrs


def _version(path, value) -> int:
    """The file's format version as a whole number this pardem reads, else a SceneError."""
    if isinstance(value, bytes):
        value = value.decode(errors="replace")
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        version = int(value)
    elif isinstance(value, str) and value.strip().isdigit():
        version = int(value)
    else:
        raise SceneError(f"--restart {path}: not a checkpoint this pardem can read: its format "
                         f"version {value!r} is not a whole number (this pardem reads "
                         f"versions {READS[0]} to {READS[-1]})")
    if version > READS[-1]:
        raise SceneError(f"--restart {path}: written by a later pardem (checkpoint format "
                         f"version {version}); this pardem reads versions {READS[0]} to "
                         f"{READS[-1]}: continue it with the pardem that wrote it")
    if version not in READS:
        raise SceneError(f"--restart {path}: checkpoint format version {version} is not one "
                         f"this pardem reads (versions {READS[0]} to {READS[-1]})")
    return version


JSON_ATTRS = ("scene_physics", "rings_layout", "checksums")
TEXT_ATTRS = ("fingerprint", "history_columns") + JSON_ATTRS


def _check_attrs(path, attrs: dict) -> None:
    """Each known attribute of its type: numbers finite where they must be, text as text,
    the JSON ones parsed (``scene_physics``, ``checksums``: replaced by their values)."""
    def bad(name, want):
        value = attrs[name]
        text = repr(value.item() if isinstance(value, np.generic) else value)
        raise SceneError(f"--restart {path}: corrupted checkpoint: attribute {name!r} is "
                         f"{text if len(text) <= 60 else text[:57] + '...'}, expected {want}")
    for name in TEXT_ATTRS:
        if isinstance(attrs.get(name), bytes):
            attrs[name] = attrs[name].decode(errors="replace")
        if name in attrs and not isinstance(attrs[name], str):
            bad(name, "text")
    for name in JSON_ATTRS:
        if name in attrs:
            try:
                value = json.loads(attrs[name])
            except ValueError:
                bad(name, "JSON text")
            if not isinstance(value, dict):
                bad(name, "a JSON object")
            if name != "rings_layout":  # the averages' reader parses its own
                attrs[name] = value
    for name in ("time", "dt", "ring_angle", "ring_phase"):
        if name in attrs and not (isinstance(attrs[name], (float, int, np.floating, np.integer))
                                  and np.isfinite(attrs[name])):
            bad(name, "a finite number")
    for name in ("step", "n_free", "ranks"):
        if name in attrs and not (isinstance(attrs[name], (int, np.integer))
                                  and not isinstance(attrs[name], (bool, np.bool_))
                                  and 0 <= int(attrs[name]) < 2**62):
            bad(name, "a whole number >= 0")
    if "end_snapshot" in attrs and not (np.ndim(attrs["end_snapshot"]) == 0 and
                                        attrs["end_snapshot"] in (0, 1)):
        bad("end_snapshot", "0 or 1")


def _verify(path, h5, checksums: dict | None) -> None:
    """Every dataset read once, a chunk of rows at a time, against its checksum (files
    without checksums, of an earlier pardem: read, so that damage is found here)."""
    for key in h5.keys():
        ds = h5[key]
        crc, rows = 0, ds.shape[0] if ds.ndim else 1
        try:
            if ds.ndim == 0:
                crc = zlib.crc32(np.ascontiguousarray(ds[()]).view(np.uint8).reshape(-1))
            for a in range(0, rows if ds.ndim else 0, VERIFY_ROWS):
                chunk = np.ascontiguousarray(ds[a:a + VERIFY_ROWS])
                crc = zlib.crc32(chunk.view(np.uint8).reshape(-1), crc)
        except DAMAGED as e:
            raise SceneError(f"--restart {path}: corrupted checkpoint: dataset {key!r} cannot "
                             f"be read ({str(e) or type(e).__name__})") from e
        if checksums is not None and checksums.get(key, crc) != crc:
            raise SceneError(f"--restart {path}: corrupted checkpoint: dataset {key!r} does "
                             "not match its checksum (the file was changed or damaged after "
                             "it was written)")


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
    if "rings_layout" in attrs:  # the ring samples so far: the restart continues from them
        for key, ndim in (("rings_sums", 3), ("rings_times", 1)):
            a = arrays.get(key)
            if a is None or a.dtype.kind not in "iuf" or a.ndim != ndim:
                raise SceneError(f"--restart {path}: corrupted checkpoint: its ring samples "
                                 f"({key}) are missing or not a {ndim}-D array of numbers")
        loads = [k for k in ("rings_loads", "rings_inner_torque") if k in arrays]
        if not loads or any(arrays[k].dtype.kind not in "iuf" for k in loads):
            raise SceneError(f"--restart {path}: corrupted checkpoint: the ring loads of its "
                             "samples (rings_loads) are missing or not numbers")
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

"""Particle snapshots in one HDF5 file, ``particles.h5``.

Stage: output. Layout (all SI units; rows sorted by particle id):

    /                         attrs: format = "pardem-snapshots", version = 1
    /snapshots/NNNNNN/        attrs: time (s), step; one group per snapshot, NNNNNN = 0, 1, ...
        id [N] int64, kind [N] int8 (0 free, 1 inner wall disk, 2 outer wall disk)
        position [N,2] m, velocity [N,2] m/s, omega [N] rad/s, theta [N] rad,
        radius [N] m, mass [N] kg (inf for wall disks), force [N,2] N, torque [N] N m,
        coordination [N] (touching disk-disk contacts)
        contacts/ ids [M,2] (id_i < id_j), normal [M,2] (unit, from j to i), overlap [M] m,
                  normal_force [M] N (on i, along normal), tangential_force [M,2] N (on i),
                  spring [M,2] m (tangential spring xi)
        ring_contacts/ (free particles touching a flat ring surface) id [K], ring [K] (1 inner,
                  2 outer), normal [K,2] (unit, from the surface to the particle), overlap [K] m,
                  normal_force [K] N, tangential_force [K,2] N, spring [K,2] m

A snapshot group is written under a temporary name and renamed when complete, so a reader never
sees a half-written snapshot; the file is opened, appended and closed for every snapshot.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np

FILE = "particles.h5"


def write_snapshot(out_dir: str | os.PathLike, index: int, time: float, step: int,
                   particles: dict[str, np.ndarray],
                   contacts: dict[str, np.ndarray] | None,
                   ring_contacts: dict[str, np.ndarray] | None = None) -> None:
    path = Path(out_dir) / FILE
    with h5py.File(path, "a") as h5:
        h5.attrs["format"] = "pardem-snapshots"
        h5.attrs["version"] = 1
        snaps = h5.require_group("snapshots")
        name = f"{index:06d}"
        tmp = "_incomplete_" + name
        if tmp in snaps:
            del snaps[tmp]
        if name in snaps:  # a restart rewrites snapshots after its checkpoint
            del snaps[name]
        g = snaps.create_group(tmp)
        g.attrs["time"] = time
        g.attrs["step"] = step
        for key, arr in particles.items():
            g.create_dataset(key, data=arr)
        for group, table in (("contacts", contacts), ("ring_contacts", ring_contacts)):
            if table is not None:
                c = g.create_group(group)
                for key, arr in table.items():
                    c.create_dataset(key, data=arr)
        snaps.move(tmp, name)


def read_snapshots(out_dir: str | os.PathLike) -> Iterator[dict]:
    """Yield the snapshots of a run folder in time order: dicts with ``time``, ``step``, the
    particle arrays keyed as in the layout above, and ``contacts`` and ``ring_contacts`` (dicts,
    or absent)."""
    path = Path(out_dir) / FILE
    if not path.exists():
        raise FileNotFoundError(f"no snapshots: {path} does not exist")
    with h5py.File(path, "r") as h5:
        names = sorted(k for k in h5.get("snapshots", {}) if not k.startswith("_"))
        for name in names:
            g = h5["snapshots"][name]
            snap = {"time": float(g.attrs["time"]), "step": int(g.attrs["step"])}
            for key, ds in g.items():
                if isinstance(ds, h5py.Dataset):
                    snap[key] = ds[()]
                else:
                    snap[key] = {k: v[()] for k, v in ds.items()}
            yield snap

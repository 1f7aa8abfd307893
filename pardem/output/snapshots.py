"""Particle snapshots: ``particles.h5`` plus the XDMF indexes ``particles.xdmf`` and
``contacts.xdmf`` that ParaView, pyvista and meshio open (see ``xdmf.py``).

Stage: output. Layout of ``particles.h5`` (all SI units; particle rows sorted by id; 2D vectors
are stored with a third component z = 0, as ParaView wants; ``read_snapshots`` drops it):

    /                         attrs: format = "pardem-snapshots", version = 2
    /topology/vertices_N      [N,1] int32 0..N-1: the Polyvertex connectivity for N particles
    /snapshots/NNNNNN/        attrs: time (s), step; one group per snapshot, NNNNNN = 0, 1, ...
        id [N] int64, kind [N] int32 (0 free, 1 inner wall disk, 2 outer wall disk),
        rank [N] int32 (owning MPI rank; -1 for wall disks, which every rank moves),
        position [N,3] m, velocity [N,3] m/s, omega [N] rad/s, theta [N] rad,
        radius [N] m, mass [N] kg (inf for wall disks), force [N,3] N, torque [N] N m
        (0 for wall disks), coordination [N] int32 (touching disk-disk contacts)
        contacts/ ids [M,2] (id_i < id_j), cells [M,2] int32 (the two particles' rows),
                  normal [M,3] (unit, from j to i), overlap [M] m,
                  normal_force [M] N (on i, along normal), tangential_force [M,3] N (on i),
                  spring [M,3] m (tangential spring xi), mobilised [M] (|f_t| / (mu |f_n|),
                  friction used), sliding [M] int32 (mobilised >= 0.999: at the Coulomb cap),
                  displacement [M,3] m (the paper's total tangential displacement eta,
                  eq. 1.3; with friction and contacts output)
        ring_contacts/ (free particles touching a flat ring surface) id [K], ring [K] (1 inner,
                  2 outer), normal [K,3] (unit, from the surface to the particle), overlap [K] m,
                  normal_force [K] N, tangential_force [K,3] N, spring [K,3] m,
                  displacement [K,3] m

Crash safety: a snapshot group is written under a temporary name and renamed when complete, the
file is opened, appended and closed for every snapshot, and the XDMF indexes are rewritten
(temporary name, then rename) only after the HDF5 file is closed, so they list complete
snapshots only (tested by killing runs with SIGKILL at random moments). A process killed
between snapshots leaves every earlier snapshot readable.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np

from . import xdmf

FILE = "particles.h5"
VECTORS = ("position", "velocity", "force", "normal", "tangential_force", "spring",
           "displacement")
SMALL_INTS = ("kind", "rank", "coordination", "ring", "sliding")  # int32: every reader knows it


def write_snapshot(out_dir: str | os.PathLike, index: int, time: float, step: int,
                   particles: dict[str, np.ndarray],
                   contacts: dict[str, np.ndarray] | None,
                   ring_contacts: dict[str, np.ndarray] | None = None) -> None:
    """Snapshot number ``index`` into DIR/particles.h5 and the XDMF indexes. Snapshots of the
    same or a later index (left by a run that this one continues from a checkpoint) are
    removed first: they belong to the abandoned tail of that run."""
    out_dir = Path(out_dir)
    with h5py.File(out_dir / FILE, "a") as h5:
        h5.attrs["format"] = "pardem-snapshots"
        h5.attrs["version"] = 2
        n = particles["id"].size
        if f"topology/vertices_{n}" not in h5:
            h5.create_dataset(f"topology/vertices_{n}",
                              data=np.arange(n, dtype=np.int32).reshape(n, 1))
        snaps = h5.require_group("snapshots")
        name = f"{index:06d}"
        earlier = any(k < name for k in snaps)
        for old in [k for k in snaps if k.startswith("_") or k >= name]:
            del snaps[old]
        tmp = "_incomplete_" + name
        g = snaps.create_group(tmp)
        g.attrs["time"] = time
        g.attrs["step"] = step
        parts = _write_table(g, particles)
        if contacts is not None:
            cells = np.searchsorted(particles["id"], contacts["ids"]).astype(np.int32)
            links = _write_table(g.create_group("contacts"), {**contacts, "cells": cells})
        if ring_contacts is not None:
            _write_table(g.create_group("ring_contacts"), ring_contacts)
        snaps.move(tmp, name)
    if earlier and not (out_dir / f"{xdmf.PARTICLES}.xdmf").exists():
        with h5py.File(out_dir / FILE, "r") as h5:
            xdmf.rebuild(h5, out_dir, FILE)
        return
    xdmf.append(out_dir, xdmf.PARTICLES, index, xdmf.particle_grid(FILE, index, time, parts))
    if contacts is not None:
        xdmf.append(out_dir, xdmf.CONTACTS, index,
                    xdmf.contact_grid(FILE, index, time, parts, links)
                    if contacts["ids"].shape[0] else None)


def _write_table(group: h5py.Group, table: dict[str, np.ndarray]) -> xdmf.Arrays:
    """Write the columns (2D vectors padded with z = 0); returns their (shape, dtype)."""
    written = {}
    for key, arr in table.items():
        if key in VECTORS:
            arr = np.column_stack([arr, np.zeros(len(arr))])
        elif key in SMALL_INTS:
            arr = np.asarray(arr, dtype=np.int32)
        ds = group.create_dataset(key, data=arr)
        written[key] = (ds.shape, ds.dtype)
    return written


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
                    snap[key] = _read(key, ds)
                else:
                    snap[key] = {k: _read(k, v) for k, v in ds.items()}
            yield snap


def _read(key: str, ds: h5py.Dataset) -> np.ndarray:
    return ds[:, :2] if key in VECTORS else ds[()]

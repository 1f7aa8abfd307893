"""Particle snapshots: one HDF5 file per snapshot in ``DIR/snapshots/``, plus the XDMF indexes
``particles.xdmf`` and ``contacts.xdmf`` that ParaView, pyvista and meshio open (``xdmf.py``).

Stage: output (rank 0). Layout of ``snapshots/NNNNNN.h5`` (NNNNNN = 0, 1, ...: the snapshot's
place in the folder's series, ``series.py``; all SI units; particle rows sorted by id; 2D
vectors are stored with a third component z = 0, as ParaView wants; ``read_snapshots`` drops
it):

    /                  attrs: format = "pardem-snapshot", version = 3, time (s), step
        topology [N,1] int32 0..N-1: the Polyvertex connectivity for N particles
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

Crash safety (a kill -9 at any moment damages at most the snapshot being written): a file is
written as ``NNNNNN.h5.tmp`` and renamed when closed, so a completed file is never opened for
writing again; the XDMF indexes are rewritten under a temporary name and renamed after the
file is in place, so they list completed files only. A run continued from a checkpoint, at its
first snapshot, drops the abandoned tail (snapshots at or after that index) from the indexes,
then deletes those files, highest first: a kill in between leaves the indexes listing the
series before that index and some unlisted files after it, which the next run deletes. No
fsync: a kill of the process is covered, a crash of the machine is not. Tested by
``run_scripts/tools/kill_loop.py`` (hundreds of kill -9 at random moments).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np

from . import xdmf
from .atomic import size_of, writing
from .xdmf import snapshot_indexes

FOLDER = xdmf.FOLDER
FORMAT = "pardem-snapshot"
VERSION = 3
VECTORS = ("position", "velocity", "force", "normal", "tangential_force", "spring",
           "displacement")
SMALL_INTS = ("kind", "rank", "coordination", "ring", "sliding")  # int32: every reader knows it


def write_snapshot(out_dir: str | os.PathLike, index: int, time: float, step: int,
                   particles: dict[str, np.ndarray],
                   contacts: dict[str, np.ndarray] | None,
                   ring_contacts: dict[str, np.ndarray] | None = None) -> None:
    """Snapshot number ``index`` into DIR/snapshots/ and the XDMF indexes. Snapshots of a later
    index (the abandoned tail of a run that this one continues from a checkpoint) are removed
    first; one of the same index is replaced."""
    out_dir = Path(out_dir)
    folder = out_dir / FOLDER
    folder.mkdir(exist_ok=True)
    stored = snapshot_indexes(out_dir)
    tail = [i for i in stored if i > index]
    if tail or (stored and stored[-1] == index):
        xdmf.truncate(out_dir, index)
        for i in reversed(tail):
            (folder / xdmf.file_name(i)).unlink()
    for stale in folder.glob("*.tmp"):  # left by a killed writer
        stale.unlink()
    path = folder / xdmf.file_name(index)
    with writing(path, size_of(particles, contacts, ring_contacts)) as tmp, \
            h5py.File(tmp, "w") as h5:
        h5.attrs.update({"format": FORMAT, "version": VERSION, "time": time, "step": step})
        n = particles["id"].size
        h5.create_dataset("topology", data=np.arange(n, dtype=np.int32).reshape(n, 1))
        parts = _write_table(h5, particles)
        if contacts is not None:
            cells = np.searchsorted(particles["id"], contacts["ids"]).astype(np.int32)
            links = _write_table(h5.create_group("contacts"), {**contacts, "cells": cells})
        if ring_contacts is not None:
            _write_table(h5.create_group("ring_contacts"), ring_contacts)
    if any(i < index for i in stored) and not (out_dir / f"{xdmf.PARTICLES}.xdmf").exists():
        xdmf.rebuild(out_dir)  # an index lost (deleted by hand): rebuilt from the files
        return
    xdmf.append(out_dir, xdmf.PARTICLES, index, xdmf.particle_grid(index, time, parts))
    if contacts is not None:
        xdmf.append(out_dir, xdmf.CONTACTS, index,
                    xdmf.contact_grid(index, time, parts, links)
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
    out_dir = Path(out_dir)
    indexes = snapshot_indexes(out_dir)
    if not indexes:
        if (out_dir / "particles.h5").exists():
            raise FileNotFoundError(f"{out_dir}: its snapshots are in one particles.h5, the "
                                    "layout of earlier pardem versions (one file per snapshot "
                                    "in snapshots/ now); rerun, or read it with that version")
        raise FileNotFoundError(f"no snapshots: {out_dir / FOLDER} holds no snapshot files")
    for index in indexes:
        with h5py.File(out_dir / FOLDER / xdmf.file_name(index), "r") as h5:
            if h5.attrs.get("format") != FORMAT:
                raise ValueError(f"{h5.filename} is not a pardem snapshot")
            snap = {"time": float(h5.attrs["time"]), "step": int(h5.attrs["step"])}
            for key, ds in h5.items():
                if isinstance(ds, h5py.Dataset):
                    if key != "topology":
                        snap[key] = _read(key, ds)
                else:
                    snap[key] = {k: _read(k, v) for k, v in ds.items()}
        yield snap


def _read(key: str, ds: h5py.Dataset) -> np.ndarray:
    return ds[:, :2] if key in VECTORS else ds[()]

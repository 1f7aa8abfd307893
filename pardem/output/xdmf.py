"""XDMF indexes over the snapshot files: ``particles.xdmf`` (disks as points) and
``contacts.xdmf`` (contacts as line cells between the two centres: the force-chain network).

Stage: output. Both are temporal collections of one Uniform grid per snapshot whose datasets
stay in that snapshot's file ``snapshots/NNNNNN.h5`` (no data is copied; paths are relative to
the index, so a run folder can be moved). Each snapshot appends its grid to the index: the
earlier grids are kept as text (grids of the same or a later index, left by a run that a
restart continues, are dropped), and the index is written under a temporary name and renamed,
so it only ever lists complete snapshots. ``rebuild`` recreates both from the files, which a
restart does when ``problems`` finds them out of step with the files (deleted or cut short).

Reader notes that shaped the layout:
- ParaView's default XDMF reader (Xdmf3) shows 0 cells for a Polyvertex topology without a
  connectivity DataItem, so one is always written (``topology`` in each file).
- 2D data is stored padded to 3 components (z = 0), as ParaView expects XYZ points and vectors.
- meshio's ``TimeSeriesReader`` takes points and cells from the first grid only and per-step
  arrays from the attributes; so the positions are also an attribute (``position``), pointing at
  the same dataset as the geometry.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import h5py
import numpy as np

FOLDER = "snapshots"
PARTICLES = "particles"
CONTACTS = "contacts"
SKIP = {PARTICLES: ("contacts", "ring_contacts"), CONTACTS: ("cells", "ids")}
_HEAD = ('<?xml version="1.0"?>\n<Xdmf Version="3.0">\n<Domain>\n'
         '<Grid Name="{0}" GridType="Collection" CollectionType="Temporal">\n')
_TAIL = "</Grid>\n</Domain>\n</Xdmf>\n"
Arrays = dict[str, tuple[tuple[int, ...], np.dtype]]  # dataset name -> (shape, dtype)


def file_name(index: int) -> str:
    """The file of snapshot ``index`` in FOLDER."""
    return f"{index:06d}.h5"


def snapshot_indexes(out_dir: Path) -> list[int]:
    """The indexes of the completed snapshot files in a run folder, ascending."""
    folder = Path(out_dir) / FOLDER
    if not folder.is_dir():
        return []
    return sorted(int(p.name[:-3]) for p in folder.iterdir()
                  if p.name.endswith(".h5") and p.name[:-3].isdigit())


def particle_grid(index: int, time: float, arrays: Arrays) -> str:
    """The grid of snapshot ``index`` whose particle datasets (shape, dtype) are ``arrays``."""
    h5_name = f"{FOLDER}/{file_name(index)}"
    topo = _topology("Polyvertex", arrays["id"][0][0], 1, h5_name, "/topology", np.int32)
    return _grid(PARTICLES, index, time, topo, h5_name, "", "", arrays, "Node")


def contact_grid(index: int, time: float, particle_arrays: Arrays, arrays: Arrays) -> str:
    """Line cells of snapshot ``index`` over that snapshot's particle positions."""
    h5_name = f"{FOLDER}/{file_name(index)}"
    shape, dtype = arrays["cells"]
    topo = _topology("Polyline", shape[0], 2, h5_name, "/contacts/cells", dtype)
    return _grid(CONTACTS, index, time, topo, h5_name, "/contacts", "",
                 {"position": particle_arrays["position"], **arrays}, "Cell")


def append(out_dir: Path, kind: str, index: int, grid: str | None) -> None:
    """Add one snapshot's grid to ``kind``.xdmf, dropping grids of index >= ``index``. A grid
    of None (a snapshot without contacts) only drops: XDMF readers fail on a topology of zero
    cells (pyvista: "Failed to read data"), so an empty network is left out of the index."""
    path = out_dir / f"{kind}.xdmf"
    if grid is None and not path.exists():
        return
    text = _kept(path, kind, index) if path.exists() else _HEAD.format(kind) + _TAIL
    _write_atomic(path, text[:-len(_TAIL)] + (grid or "") + _TAIL)


def truncate(out_dir: Path, index: int) -> None:
    """Drop the grids of index >= ``index`` from both indexes (a restart's abandoned tail)."""
    for kind in (PARTICLES, CONTACTS):
        path = out_dir / f"{kind}.xdmf"
        if path.exists():
            text = _kept(path, kind, index)
            if len(text) < path.stat().st_size:
                _write_atomic(path, text)


def rebuild(out_dir: Path, upto: int | None = None) -> None:
    """Both indexes from every snapshot file in ``out_dir`` (of index ``upto`` or less; reads
    each file; for folders whose index was lost or damaged); an index without grids is
    removed, so none names a file that is gone."""
    particles, contacts = [], []
    for index in snapshot_indexes(out_dir):
        if upto is not None and index > upto:
            break
        with h5py.File(out_dir / FOLDER / file_name(index), "r") as h5:
            time = float(h5.attrs["time"])
            parts = _shapes(h5)
            particles.append(particle_grid(index, time, parts))
            if "contacts" in h5 and h5["contacts"]["cells"].shape[0]:  # no empty grids
                contacts.append(contact_grid(index, time, parts, _shapes(h5["contacts"])))
    for kind, grids in ((PARTICLES, particles), (CONTACTS, contacts)):
        if grids:
            _write_atomic(out_dir / f"{kind}.xdmf", _HEAD.format(kind) + "".join(grids) + _TAIL)
        else:
            (out_dir / f"{kind}.xdmf").unlink(missing_ok=True)


def problems(out_dir: Path, kept: list[int]) -> list[str]:
    """What is wrong with the indexes of a folder whose series is the files ``kept`` (more
    files, a tail past a restart's checkpoint, may follow): an index cut short, naming files
    that are gone, or (particles.xdmf) leaving some of ``kept`` out."""
    on_disk = set(snapshot_indexes(out_dir))
    found = []
    for kind in (PARTICLES, CONTACTS):
        path = out_dir / f"{kind}.xdmf"
        if not path.exists():
            if kind == PARTICLES and kept:
                found.append(f"{path.name} was missing")
            continue
        text = path.read_text(errors="replace")
        listed = [i for i, _ in _grids(text, kind)]
        gone = [i for i in listed if i not in on_disk]
        left_out = sorted(set(kept) - set(listed)) if kind == PARTICLES else []
        if not text.endswith(_TAIL):
            found.append(f"{path.name} was cut short")
        if gone:
            found.append(f"{path.name} named {_files(gone)} that "
                         f"{'is' if len(gone) == 1 else 'are'} not in {FOLDER}/")
        if left_out:
            found.append(f"{path.name} left out {_files(left_out)}")
    return found


def _files(indexes: list[int]) -> str:
    """"3 snapshot files (000004.h5 to 000006.h5)", for the log."""
    if len(indexes) == 1:
        return f"1 snapshot file ({file_name(indexes[0])})"
    return (f"{len(indexes)} snapshot files ({file_name(indexes[0])} to "
            f"{file_name(indexes[-1])})")


def _kept(path: Path, kind: str, index: int) -> str:
    """The index at ``path`` without its grids of index >= ``index``."""
    text = path.read_text()
    last = text.rfind(f'<Grid Name="{kind}_')
    if last >= 0 and int(text[last + len(kind) + 13:].split('"', 1)[0]) >= index:
        text = _HEAD.format(kind) + "".join(g for i, g in _grids(text, kind) if i < index) + _TAIL
    return text


def _shapes(group: h5py.Group) -> Arrays:
    return {k: (ds.shape, ds.dtype) for k, ds in group.items()
            if isinstance(ds, h5py.Dataset) and k != "topology"}


def _grids(text: str, kind: str) -> list[tuple[int, str]]:
    return [(int(m.group(1)), m.group(0)) for m in
            re.finditer(rf'<Grid Name="{kind}_(\d+)" GridType="Uniform">.*?</Grid>\n', text,
                        flags=re.DOTALL)]


def _grid(kind: str, index: int, time: float, topology: str, h5_name: str, path: str,
          points: str, arrays: Arrays, center: str) -> str:
    shape, dtype = arrays["position"]
    parts = [f'<Grid Name="{kind}_{index:06d}" GridType="Uniform">\n<Time Value="{time!r}"/>\n',
             topology, '<Geometry GeometryType="XYZ">\n',
             _item(h5_name, f"{points}/position", shape, dtype), "</Geometry>\n"]
    for key, (shape, dtype) in sorted(arrays.items()):
        if key in SKIP[kind] or (kind == CONTACTS and key == "position"):
            continue
        kind_of = {1: "Scalar", 2: "Vector" if shape[-1] == 3 else "Matrix"}[len(shape)]
        parts += [f'<Attribute Name="{key}" AttributeType="{kind_of}" Center="{center}">\n',
                  _item(h5_name, f"{path}/{key}", shape, dtype), "</Attribute>\n"]
    parts.append("</Grid>\n")
    return "".join(parts)


def _topology(kind: str, n: int, per: int, h5_name: str, path: str, dtype) -> str:
    return (f'<Topology TopologyType="{kind}" NumberOfElements="{n}" NodesPerElement="{per}">\n'
            + _item(h5_name, path, (n, per), np.dtype(dtype)) + "</Topology>\n")


def _item(h5_name: str, path: str, shape: tuple[int, ...], dtype) -> str:
    dtype = np.dtype(dtype)
    number = {"f": "Float", "i": "Int", "u": "UInt"}[dtype.kind]
    dims = " ".join(str(s) for s in shape)
    return (f'<DataItem Dimensions="{dims}" NumberType="{number}" Precision="{dtype.itemsize}" '
            f'Format="HDF">{h5_name}:{path}</DataItem>\n')


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)

"""Ring fields on an annulus mesh for ParaView: ``rings.vtu``.

Stage: averaging output. One quad cell per ring and angular segment (the fields are axisymmetric,
so every segment of a ring carries the ring's values; the segments only give ParaView a surface
to colour: 120 per ring, fewer for thousands of rings, ``segments_for``). Cell data: every per-ring field of ``RingAverager.fields`` (with its ``_err``), the
tensors F, sigma, eps as 3x3 components in the polar frame (r, phi, z; rows and columns in that
order, z entries zero), and ``velocity``, the mean velocity as a Cartesian vector at the cell
centre (for arrows). Written under a temporary name and renamed.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import meshio
import numpy as np

SEGMENTS = 120  # 3 degrees: the chord deviates from the arc by < 0.04 % of the radius
MESH_CELLS = 200_000
"""Cells the mesh may have before its rings get fewer segments (at least ``MIN_SEGMENTS``):
every cell repeats its ring's ~110 values, and meshio held ~2.4 kB per cell while writing
(10,000 rings of 120 segments: 2.8 GB), far beyond the run itself."""
MIN_SEGMENTS = 3
VTU_BYTES_PER_CELL = 2400
"""Peak bytes per cell while ``write_rings_vtu`` runs (measured, for memory estimates)."""


def segments_for(n_rings: int) -> int:
    """Angular segments per ring: ``SEGMENTS``, fewer where the rings are so many that the
    mesh would pass ``MESH_CELLS``."""
    return max(MIN_SEGMENTS, min(SEGMENTS, MESH_CELLS // max(n_rings, 1)))
TENSORS = ("F", "sigma", "eps")


def annulus(r_edges: np.ndarray, segments: int = SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """Points [(R+1)*S, 3] and quads [R*S, 4] (counter-clockwise) of rings with radii
    ``r_edges`` [R+1] cut into ``segments`` angular pieces; cell k = ring * S + segment."""
    phi = 2.0 * math.pi * np.arange(segments) / segments
    rr, pp = np.meshgrid(r_edges, phi, indexing="ij")
    points = np.column_stack([(rr * np.cos(pp)).ravel(), (rr * np.sin(pp)).ravel(),
                              np.zeros(rr.size)])
    ring, seg = np.meshgrid(np.arange(r_edges.size - 1), np.arange(segments), indexing="ij")
    a = ring * segments + seg
    b = ring * segments + (seg + 1) % segments
    quads = np.column_stack([a.ravel(), b.ravel(), (b + segments).ravel(), (a + segments).ravel()])
    return points, quads


def write_rings_vtu(path: str | Path, fields: dict[str, np.ndarray], r_edges: np.ndarray,
                    segments: int | None = None) -> None:
    path = Path(path)
    segments = segments_for(r_edges.size - 1) if segments is None else segments
    points, quads = annulus(r_edges, segments)
    n_rings = r_edges.size - 1
    ring = np.repeat(np.arange(n_rings), segments)
    data = {k: np.asarray(v, float)[ring] for k, v in fields.items()
            if np.ndim(v) == 1 and len(v) == n_rings}
    for name in TENSORS:
        t = np.zeros((n_rings, 9))
        for a, ca in enumerate(("r", "phi")):
            for b, cb in enumerate(("r", "phi")):
                t[:, 3 * a + b] = fields[f"{name}_{ca}{cb}"]
        data[name] = t[ring]
    centre = 2.0 * math.pi * (np.arange(segments) + 0.5) / segments
    phi = np.tile(centre, n_rings)
    v_r, v_phi = data["v_r"], data["v_phi"]
    data["velocity"] = np.column_stack([v_r * np.cos(phi) - v_phi * np.sin(phi),
                                        v_r * np.sin(phi) + v_phi * np.cos(phi),
                                        np.zeros(phi.size)])
    data["ring"] = ring.astype(np.int32)
    mesh = meshio.Mesh(points, [("quad", quads)], cell_data={k: [v] for k, v in data.items()})
    tmp = path.with_name(path.name + ".tmp")
    mesh.write(tmp, file_format="vtu")
    os.replace(tmp, path)

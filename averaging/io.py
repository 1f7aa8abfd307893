"""Ring averages on disk: ``rings.h5`` (fields with units and standard errors, the raw sums of
every sample, sample times, the inner-ring torque per sample), ``rings.csv`` (the per-ring
fields, units in the column names) and ``rings.vtu`` (the annulus mesh for ParaView, mesh.py);
``read_rings`` reads them back.

Stage: averaging output (rank 0). Every file is written under a temporary name and renamed.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np

from pardem.sampling import size_of, writing

from .fields import COLUMNS, FIELD_UNITS, UNITS
from .mesh import write_rings_vtu


def write_rings(out_dir: Path, avg) -> None:
    """The files of a RingAverager ``avg`` into out_dir (rings.h5 through
    pardem.output.atomic: refused before h5py writes when there is no room)."""
    f = avg.fields()
    sums = np.array(avg.samples)
    with writing(out_dir / "rings.h5", size_of(f, {"sums": sums})) as tmp:
        _write_h5(tmp, avg, f, sums)
    keys = [k for k in f if np.ndim(f[k]) == 1]  # per-ring columns (fit scalars: h5 only)
    header = ",".join(f"{k} [{FIELD_UNITS.get(k.removesuffix('_err'), '')}]" for k in keys)
    tmp = out_dir / "rings.csv.tmp"
    np.savetxt(tmp, np.column_stack([f[k] for k in keys]), delimiter=",", header=header,
               comments="")
    os.replace(tmp, out_dir / "rings.csv")
    write_rings_vtu(out_dir / "rings.vtu", f, avg.r_in + np.arange(avg.n_rings + 1) * avg.dr)


def _write_h5(tmp: Path, avg, f: dict, sums: np.ndarray) -> None:
    with h5py.File(tmp, "w") as h5:
        h5.attrs.update({"format": "pardem-rings", "ring_width": avg.dr,
                         "inner_radius": avg.r_in, "weighting": avg.weighting,
                         "height": avg.height, "n_samples": len(avg.samples),
                         "reference_diameter": avg.d_ref})
        for key, value in f.items():
            h5.create_dataset(f"fields/{key}", data=value)
            h5[f"fields/{key}"].attrs["unit"] = FIELD_UNITS.get(key.removesuffix("_err"), "")
        h5.create_dataset("sums", data=sums)
        h5["sums"].attrs["columns"] = ",".join(COLUMNS)
        h5["sums"].attrs["units"] = ",".join(UNITS[c] for c in COLUMNS)
        h5.create_dataset("times", data=np.array(avg.times))
        h5.create_dataset("inner_torque", data=np.array(avg.torques))
        h5["inner_torque"].attrs["unit"] = "N m"


def read_rings(run_dir: str | Path) -> dict[str, np.ndarray]:
    """Fields (with ``_err`` standard errors) from DIR/rings.h5, plus ``times`` and ``sums``."""
    with h5py.File(Path(run_dir) / "rings.h5", "r") as h5:
        out = {k: v[()] for k, v in h5["fields"].items()}
        out["times"] = h5["times"][()]
        out["sums"] = h5["sums"][()]
        if "inner_torque" in h5:  # files written before the torque was recorded lack it
            out["inner_torque_samples"] = h5["inner_torque"][()]
        if "reference_diameter" in h5.attrs:
            out["reference_diameter"] = float(h5.attrs["reference_diameter"])
        out["columns"] = tuple(h5["sums"].attrs["columns"].split(","))
    return out

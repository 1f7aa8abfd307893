"""Ring averages on disk: ``rings.h5`` (fields with units and standard errors, the raw sums of
every sample, sample times, the loads on both rings per sample, the normalisations),
``rings.csv`` (the per-ring fields), ``rings_blocks.csv`` (the fields of the consecutive
blocks of samples the errors come from, with their times), ``ring_loads.csv`` (the loads on
the rings at every sample time, boundary.LOADS) and ``rings.vtu`` (the annulus mesh for
ParaView, mesh.py); ``read_rings`` reads them back, ``tables.py`` as xarray and pandas.

The CSV files open in any reader as they are: plain column names, one row per ring (per block
and ring), and the units in a comment line above the header (``pandas.read_csv(path,
comment="#")`` skips it; ``csv_units`` reads it).

Stage: averaging output (rank 0). Every file is written under a temporary name and renamed.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import h5py
import numpy as np

from pardem.sampling import size_of, writing

from .boundary import LOADS
from .fields import COLUMNS, FIELD_UNITS, UNITS
from .mesh import write_rings_vtu


def write_rings(out_dir: Path, avg) -> None:
    """The files of a RingAverager ``avg`` into out_dir (rings.h5 through
    pardem.output.atomic: refused before h5py writes when there is no room)."""
    f, per = avg.fields_and_blocks()
    sums = np.array(avg.samples)
    with writing(out_dir / "rings.h5", size_of(f, {"sums": sums})) as tmp:
        _write_h5(tmp, avg, f, sums)
    keys = [k for k in f if np.ndim(f[k]) == 1]  # per-ring columns (fit scalars: h5 only)
    write_csv(out_dir / "rings.csv", keys, np.column_stack([f[k] for k in keys]))
    write_csv(out_dir / "rings_blocks.csv", *block_table(avg, per))
    write_csv(out_dir / "ring_loads.csv", ["time", *LOADS],
              np.column_stack([avg.times, avg.load_table()]))
    write_rings_vtu(out_dir / "rings.vtu", f, avg.r_in + np.arange(avg.n_rings + 1) * avg.dr)


def block_table(avg, per: list[dict]) -> tuple[list[str], np.ndarray]:
    """(columns, rows) of rings_blocks.csv: per block of samples (RingAverager.blocks; their
    fields ``per``) and ring, the block's mean sample time, its first and last sample time,
    the ring index, and every per-ring field of the block's averaged sums."""
    blocks = avg.blocks()
    args = avg.field_arguments()
    keys = ["r", "r_tilde"] + [k for k in per[0] if np.ndim(per[0][k]) == 1]
    times, n = np.array(avg.times), avg.n_rings
    rows = []
    for b, f in zip(blocks, per):
        f = {"r": args[0], "r_tilde": args[3], **f}
        head = np.tile([times[b].mean(), times[b][0], times[b][-1]], (n, 1))
        rows.append(np.column_stack([head, np.arange(n), *(f[k] for k in keys)]))
    return ["time", "time_start", "time_end", "ring"] + keys, np.vstack(rows)


def write_csv(path: Path, columns: list[str], rows: np.ndarray) -> None:
    """A CSV file with plain column names and a comment line of their units above them,
    written under a temporary name and renamed."""
    units = ",".join(column_unit(c) for c in columns)
    tmp = path.with_name(path.name + ".tmp")
    np.savetxt(tmp, rows, delimiter=",", header=f"# units: {units}\n" + ",".join(columns),
               comments="")
    os.replace(tmp, path)


def ring_load_samples(h5) -> np.ndarray:
    """The ring loads of every sample [samples, len(LOADS)] from an open rings.h5 (NaN where
    the file predates them: the inner torque alone, or nothing)."""
    if "ring_loads" in h5:
        return h5["ring_loads"][()]
    loads = np.full((h5["times"].shape[0], len(LOADS)), np.nan)
    if "inner_torque" in h5:
        loads[:, 0] = h5["inner_torque"][()]
    return loads


def column_unit(column: str) -> str:
    """The unit of a column of the ring tables ("1": dimensionless)."""
    if column in ("time", "time_start", "time_end"):
        return "s"
    return "1" if column == "ring" else FIELD_UNITS.get(column.removesuffix("_err"), "")


def csv_units(path: str | Path) -> dict[str, str]:
    """Column name -> unit of a ring table CSV (its ``# units:`` comment line)."""
    with open(path) as f:
        units = f.readline().removeprefix("# units: ").strip().split(",")
        return dict(zip(f.readline().strip().split(","), units))


def _write_h5(tmp: Path, avg, f: dict, sums: np.ndarray) -> None:
    args = avg.field_arguments()
    with h5py.File(tmp, "w") as h5:
        h5.attrs.update({"format": "pardem-rings", "ring_width": avg.dr,
                         "inner_radius": avg.r_in, "weighting": avg.weighting,
                         "height": avg.height, "n_samples": len(avg.samples),
                         "reference_diameter": avg.d_ref, "k_n_2d": args[4],
                         "wall_speed": args[5]})
        for key, value in f.items():
            h5.create_dataset(f"fields/{key}", data=value)
            h5[f"fields/{key}"].attrs["unit"] = FIELD_UNITS.get(key.removesuffix("_err"), "")
        h5.create_dataset("sums", data=sums)
        h5["sums"].attrs["columns"] = ",".join(COLUMNS)
        h5["sums"].attrs["units"] = ",".join(UNITS[c] for c in COLUMNS)
        h5.create_dataset("times", data=np.array(avg.times))
        loads = avg.load_table()
        h5.create_dataset("ring_loads", data=loads)
        h5["ring_loads"].attrs["columns"] = ",".join(LOADS)
        h5["ring_loads"].attrs["units"] = ",".join(FIELD_UNITS[k] for k in LOADS)
        h5.create_dataset("inner_torque", data=loads[:, 0])  # what older readers look for
        h5["inner_torque"].attrs["unit"] = "N m"


RINGS_MEMBERS = ("fields/r", "fields/r_tilde", "sums", "times")
"""What every reader of rings.h5 needs: the ring radii, the sums of every sample and their times
(``_write_h5`` writes them all, so a file without one is damaged or not pardem's)."""


class RingsFileError(ValueError):
    """A rings.h5 that cannot be read, with its path and what is wrong with it."""


@contextlib.contextmanager
def open_rings(path: str | Path):
    """The rings.h5 at ``path`` open for reading, once it holds ``RINGS_MEMBERS``: else
    RingsFileError naming the file and what it lacks, or why it does not open as HDF5, where
    h5py's KeyError and OSError name neither (a damaged or partly copied file, another
    program's)."""
    try:
        h5 = h5py.File(path, "r")
    except FileNotFoundError:
        raise
    except OSError as e:
        raise RingsFileError(f"{path}: not readable as HDF5 ({e}): a damaged or partly copied "
                             "rings.h5? `pardem average RUN_DIR` writes it anew from the "
                             "snapshots") from None
    with h5:
        missing = [m for m in RINGS_MEMBERS if m not in h5]
        if missing:
            raise RingsFileError(f"{path}: damaged or not pardem's ring averages: no "
                                 f"{', '.join(missing)} (a pardem rings.h5 holds "
                                 f"{', '.join(RINGS_MEMBERS)}); `pardem average RUN_DIR` "
                                 "writes it anew from the snapshots")
        yield h5


def read_rings(run_dir: str | Path) -> dict[str, np.ndarray]:
    """Fields (with ``_err`` standard errors) from DIR/rings.h5, plus ``times`` and ``sums``."""
    with open_rings(Path(run_dir) / "rings.h5") as h5:
        out = {k: v[()] for k, v in h5["fields"].items()}
        out["times"] = h5["times"][()]
        out["sums"] = h5["sums"][()]
        if "inner_torque" in h5:  # files written before the torque was recorded lack it
            out["inner_torque_samples"] = h5["inner_torque"][()]
        out["ring_loads_samples"] = ring_load_samples(h5)
        if "reference_diameter" in h5.attrs:
            out["reference_diameter"] = float(h5.attrs["reference_diameter"])
        out["columns"] = tuple(h5["sums"].attrs["columns"].split(","))
    return out

"""Ring fields where physicists work: an ``xarray.Dataset`` and a tidy ``pandas.DataFrame``
of a run's ``rings.h5``, time-averaged or time-resolved.

Stage: averaging (reading). The time average is the run's own (the fields and standard errors
stored in rings.h5). The time-resolved fields are formed from the raw sums stored for every
sample, exactly as the time average is: the sums of ``every`` consecutive samples are averaged
and the fields formed from that average (``fields.group_fields``); ``every=1`` gives the fields
of single samples. Every variable carries its unit and its definition (fields.FIELDS) as
attributes. pandas and xarray are optional (``pip install pardem[data]``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .boundary import LOAD_DESCRIPTIONS
from .fields import FIELDS, group_fields
from .io import RingsFileError, column_unit, open_rings, ring_load_samples

DESCRIPTIONS = {"r": "ring centre radius", "r_tilde": "(r - R_i) / d_ref", **LOAD_DESCRIPTIONS,
                "time": "mean time of the samples averaged",
                **{f.name: f.definition for f in FIELDS if not f.name.startswith("_")}}


def ring_dataset(run_dir: str | Path, every: int | None = None):
    """The ring fields of ``run_dir/rings.h5`` as an xarray.Dataset.

    ``every=None``: the time average, dims ``ring``; each field ``F`` with its standard error
    ``F_err``; profile fits (fit_v0, fit_s, ...) and the ring loads (boundary.LOADS) as scalars.
    ``every=n``: time-resolved, dims ``time`` x ``ring``: the fields of each run of n
    consecutive samples (a last, shorter run included), ``time`` their mean sample time (s).
    Coordinates ``r`` (m) and ``r_tilde`` along ``ring``; attributes ``unit`` and
    ``description`` on every variable, the averaging layout on the dataset."""
    xr = _need("xarray")
    path = Path(run_dir) / "rings.h5"
    with open_rings(path) as h5:
        stored = {k: v[()] for k, v in h5["fields"].items()}
        layout = {k: (v.item() if hasattr(v, "item") else v) for k, v in h5.attrs.items()}
        sums, times = h5["sums"][()], h5["times"][()]
        loads = ring_load_samples(h5)
    r, r_tilde = stored.pop("r"), stored.pop("r_tilde")
    coords = {"ring": np.arange(r.size), "r": ("ring", r), "r_tilde": ("ring", r_tilde)}
    if every is None:
        data = {k: (("ring",) if np.ndim(v) else (), v) for k, v in stored.items()}
    else:
        if int(every) < 1:
            raise ValueError(f"every = {every}: the number of samples per time point, >= 1")
        if "k_n_2d" not in layout:
            raise ValueError(f"{path} holds no normalisations (written by an older pardem): "
                             "`pardem average RUN_DIR` writes them")
        lost = [k for k in ("ring_width", "height", "wall_speed") if k not in layout]
        if lost:  # written together with k_n_2d (io._write_h5): the file was changed since
            raise RingsFileError(f"{path}: damaged: no attribute {', '.join(lost)} beside "
                                 "k_n_2d; `pardem average RUN_DIR` writes it anew")
        groups = [np.arange(k, min(k + int(every), len(times)))
                  for k in range(0, len(times), int(every))]
        args = (r, layout["ring_width"], layout["height"], r_tilde, layout["k_n_2d"],
                layout["wall_speed"])
        per = group_fields(sums, loads, groups, args)
        coords["time"] = np.array([times[g].mean() for g in groups])
        data = {k: (("time", "ring") if np.ndim(v) else ("time",), np.array([p[k] for p in per]))
                for k, v in per[0].items()}
    ds = xr.Dataset(data, coords=coords, attrs={**layout, "source": str(path)})
    for name in list(ds.variables):
        base = str(name).removesuffix("_err")
        unit = column_unit(str(name))
        what = DESCRIPTIONS.get(base, "ring index")
        ds[name].attrs.update(unit=unit, description=what if base == name else
                              f"standard error of {base} (block averages)")
    return ds


def ring_frame(run_dir: str | Path, every: int | None = None):
    """The per-ring fields of ``ring_dataset(run_dir, every)`` as a tidy pandas.DataFrame: one
    row per ring (per time and ring when time-resolved), one column per field, with ``ring``,
    ``r``, ``r_tilde`` (and ``time``) as columns; scalars (fits, ring loads) stay in the dataset.
    The units are in ``frame.attrs["units"]``."""
    _need("pandas")
    ds = ring_dataset(run_dir, every)
    ds = ds[[k for k in ds.data_vars if "ring" in ds[k].dims]]
    frame = ds.to_dataframe().reset_index()
    frame.attrs["units"] = {c: ds[c].attrs.get("unit", "") for c in frame.columns
                            if c in ds.variables}
    return frame


def _need(module: str):
    try:
        return __import__(module)
    except ImportError:
        raise ImportError(f"{module} is needed for this table: pip install {module} "
                          "(or pip install pardem[data])") from None

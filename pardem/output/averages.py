"""The in-situ ring averages of a run and their place in checkpoints: the averager of the
scene's ``[averaging]`` table, the steps it samples, and the samples a checkpoint carries, so
that a restarted run continues the averages exactly instead of starting them again.

Stage: output / restart. A sample is the ring sums reduced over the ranks (the same on every
rank), so rank 0 writes them and every rank reads them back. A restart adds to the
checkpoint's samples only what they were taken with: the same rings, weighting, reference
diameter and contact displacement, and the same sample steps up to the checkpoint; anything
else is refused with the key that differs (``pardem average`` re-averages the snapshots with
other settings).
"""

from __future__ import annotations

import json

import numpy as np

from ..input.scene import SceneError
from ..sampling import ring_width
from ..core.scales import normal_stiffness
from .writers import sample_steps

ARRAYS = ("rings_sums", "rings_times", "rings_inner_torque", "rings_loads")
"""Checkpoint datasets: the sums of every sample [samples, rings, columns] (averaging/fields.py
names the columns), their times (s), the inner ring's torque on the particles (N m) and the
loads on both rings [samples, loads] (averaging/boundary.py's LOADS; checkpoints written
before pardem kept them hold the inner torque only, and the other loads of their samples
stay NaN)."""

# a layout entry -> the scene key a user would change to alter it
_KEYS = {"ring_width": "[averaging] ring_width", "weighting": "[averaging] weighting",
         "reference_diameter": "[averaging] reference_diameter",
         "displacement": "[averaging] displacement", "rings": "the number of rings",
         "inner_radius": "[geometry] inner_radius", "height": "[contact] height",
         "columns": "the averaged sums (a different pardem version)"}


def make_averager(scene, free_radii: np.ndarray, reducer):
    """The RingAverager of the scene's [averaging] table (None without one or without rings)."""
    cfg, g = scene.averaging, scene.geometry
    if cfg is None or g is None:
        return None
    from averaging.timeavg import RingAverager  # averaging builds on pardem

    d_ref = cfg.reference_diameter or 2.0 * float(np.mean(free_radii))
    return RingAverager(g.inner_radius, g.outer_radius, ring_width(scene), cfg.weighting,
                        scene.contact.height, d_ref, normal_stiffness(scene)[1],
                        g.omega_inner, reducer)


def sample_grid(scene, dt: float, last_step: int) -> np.ndarray:
    """Every step up to ``last_step`` the scene's [averaging] samples at (the snapshot rule:
    multiples of round(sample_interval/dt), so offline averaging of snapshots sees the same
    states)."""
    cfg = scene.averaging
    return sample_steps(cfg.start, cfg.end, cfg.sample_interval, dt, last_step)


def layout(avg, scene) -> dict:
    """What a sample depends on besides the state."""
    from averaging.fields import COLUMNS

    return {"inner_radius": avg.r_in, "ring_width": avg.dr, "rings": avg.n_rings,
            "weighting": avg.weighting, "height": avg.height, "reference_diameter": avg.d_ref,
            "displacement": scene.averaging.displacement, "columns": ",".join(COLUMNS)}


def checkpoint_part(avg, scene) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """The checkpoint datasets and attribute of the averager's samples so far."""
    from averaging.fields import N_COLUMNS

    sums = np.array(avg.samples, float).reshape(len(avg.samples), avg.n_rings, N_COLUMNS)
    loads = avg.load_table()
    arrays = {"rings_sums": sums, "rings_times": np.array(avg.times, float),
              "rings_inner_torque": loads[:, 0].copy(), "rings_loads": loads}
    return arrays, {"rings_layout": json.dumps(layout(avg, scene), sort_keys=True)}


def resume(avg, scene, dt: float, step: int, saved: dict, path, log) -> None:
    """Put the samples a checkpoint at ``step`` carries (``saved``: its ARRAYS and attribute
    ``rings_layout``, absent in files written before pardem kept them) into ``avg``. SceneError
    when the samples the scene asks for up to ``step`` are not exactly the ones saved."""
    if avg is None:
        if saved.get("rings_times") is not None and len(saved["rings_times"]):
            log(f"restart from {path}: this scene has no [averaging] table; the checkpoint's "
                f"{len(saved['rings_times'])} ring samples are not continued")
        return
    wanted = sample_grid(scene, dt, step)
    t_ckpt = step * dt
    if "rings_layout" not in saved:
        if wanted.size:
            raise SceneError(
                f"--restart {path}: the checkpoint (t = {t_ckpt:.6g} s) holds no ring samples, "
                f"but [averaging] start = {scene.averaging.start:.6g} s lies before it: the "
                f"averages would miss {wanted.size} samples. Set [averaging] start to "
                f"{t_ckpt:.6g} s or later, or average the snapshots offline (pardem average)")
        return
    if not wanted.size and not len(saved.get("rings_times", ())):
        return  # no samples before the checkpoint: nothing to continue, any layout will do
    theirs, ours = json.loads(saved["rings_layout"]), layout(avg, scene)
    for key, value in ours.items():
        if theirs.get(key) != value and key == "columns":
            raise SceneError(
                f"--restart {path}: the checkpoint's {len(saved['rings_times'])} ring samples "
                "hold other sums than this pardem version averages (written by another "
                "version); continue without them by setting [averaging] start after the "
                "checkpoint, or average the snapshots offline (pardem average)")
        if theirs.get(key) != value:
            raise SceneError(
                f"--restart {path}: the checkpoint's {len(saved['rings_times'])} ring samples "
                f"were taken with {key} = {theirs.get(key)!r}, this scene has {value!r} "
                f"({_KEYS[key]}); restart with the checkpoint's value, or average the "
                "snapshots offline with other settings (pardem average)")
    sums = np.asarray(saved["rings_sums"], float)
    times = np.asarray(saved["rings_times"], float)
    n_loads = avg.load_table().shape[1]
    loads = _loads(saved, n_loads)
    if (sums.ndim != 3 or sums.shape[1:] != (avg.n_rings, len(ours["columns"].split(",")))
            or times.shape != (sums.shape[0],) or loads.shape != (times.size, n_loads)
            or not np.isfinite(times).all()):
        raise SceneError(f"--restart {path}: corrupted checkpoint: ring samples of shape "
                         f"{sums.shape}, times {times.shape}, ring loads {loads.shape}")
    steps = np.rint(times / dt).astype(np.int64)
    if not np.array_equal(steps, wanted):
        def span(s):
            return f"{s.size} samples" + (f" at t = {s[0] * dt:.6g} .. {s[-1] * dt:.6g} s"
                                          if s.size else "")
        raise SceneError(
            f"--restart {path}: [averaging] start or sample_interval differ from the run that "
            f"wrote the checkpoint: it holds {span(steps)}, this scene samples {span(wanted)} "
            f"up to the checkpoint's t = {t_ckpt:.6g} s; restart with the checkpoint's values, "
            "or average the snapshots offline (pardem average)")
    avg.samples = list(sums)
    avg.times = times.tolist()
    avg.loads = list(loads)
    if len(times):
        log(f"restart from {path}: continuing the ring averages from its {len(times)} samples")


def _loads(saved: dict, n_loads: int) -> np.ndarray:
    """The ring loads of a checkpoint's samples [samples, n_loads]: its ``rings_loads``, or,
    from a checkpoint written before they were kept, the inner torque and NaN for the rest."""
    if saved.get("rings_loads") is not None:
        return np.asarray(saved["rings_loads"], float)
    torque = np.asarray(saved["rings_inner_torque"], float).ravel()
    loads = np.full((torque.size, n_loads), np.nan)
    loads[:, 0] = torque
    return loads

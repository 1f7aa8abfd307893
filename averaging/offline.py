"""Offline averaging: the same ring sums as in situ, from a run folder's snapshots.

Stage: averaging. Each snapshot in [start, end] (with its contacts and flat-ring contacts) is
turned into the Sample the step loop would have produced (contacts seen from each free particle,
in the same order) and passed to the same ``RingAverager.add``, so in-situ and offline results
agree to round-off.
"""

from __future__ import annotations

import math
from pathlib import Path

from pardem.sampling import (SceneError, is_sample_step, load_scene, normal_stiffness,
                             read_snapshots, resolve_dt, ring_width_problem, sample_range)
from pardem.sampling import ring_width as default_ring_width

from .sample import snapshot_sample
from .timeavg import RingAverager


def average_run(run_dir: str | Path, start: float | None = None, end: float | None = None,
                ring_width: float | None = None, weighting: str | None = None,
                displacement: str | None = None) -> RingAverager:
    """Average the snapshots of a run folder with t in [start, end] (defaults: the scene's
    [averaging] table, or the whole run; displacement "spring" unless the table says)."""
    run_dir = Path(run_dir)
    scene = load_scene(run_dir / "scene.toml")
    g, cfg = scene.geometry, scene.averaging
    if g is None:
        raise SceneError(f"{run_dir}: ring averaging needs a couette scene")
    start = start if start is not None else (cfg.start if cfg else 0.0)
    end = end if end is not None else (cfg.end if cfg else float("inf"))
    ring_width = ring_width or default_ring_width(scene)
    why = ring_width_problem(ring_width, g.outer_radius - g.inner_radius)
    if why:
        raise SceneError(f"ring width {ring_width:g} m: {why}")
    weighting = weighting or (cfg.weighting if cfg else "slice")
    displacement = displacement or (cfg.displacement if cfg else "spring")
    dt = resolve_dt(scene)
    interval = scene.output.snapshot_interval
    every = sample_range(start, end, interval, dt)[0]
    avg = None
    for snap in read_snapshots(run_dir):
        step = snap["step"]
        inside = (is_sample_step(step, start, end, interval, dt) if math.isfinite(end)
                  else step >= start / dt - every / 2)
        if not inside:
            continue
        free = snap["kind"] == 0
        if avg is None:
            d_ref = (cfg.reference_diameter if cfg and cfg.reference_diameter
                     else 2.0 * float(snap["radius"][free].mean()))
            avg = RingAverager(g.inner_radius, g.outer_radius, ring_width, weighting,
                               scene.contact.height, d_ref, normal_stiffness(scene)[1],
                               g.omega_inner)
        avg.add(snapshot_sample(snap, displacement), snap["time"])
    if avg is None:
        raise SceneError(f"{run_dir}: no snapshot between t = {start} s and {end} s")
    return avg

"""What a checkpoint holds and how a run continues from one: the whole state gathered on rank 0
(``gather_state``) and put back into the whole-cell arrays of a new run (``restore``).

Stage: output / restart. The file format itself is ``checkpoint.py``. A checkpoint holds every
particle array, the contact history keyed by gid pairs (its columns named, so a run that tracks
more or fewer columns than the one that wrote it can continue), and the forces the last step
applied to every touching pair and ring contact (so output right after a restart reports them
exactly), and the ring samples taken so far (``averages.py``). A restarted run continues bit for
bit, on any number of ranks, and so do its averages.
"""

from __future__ import annotations

import json

import numpy as np

from ..contact.history import merge_history
from ..scene import SceneError, physics_differences
from ..state import FREE
from .averages import ARRAYS as AVERAGE_ARRAYS
from .averages import checkpoint_part
from .checkpoint import ARRAYS, load_checkpoint


def gather_state(sim) -> tuple[dict[str, np.ndarray], dict[str, object]] | None:
    """The whole state of a Simulation on rank 0 (None on the others; collective): particle
    arrays sorted by gid, ``pair_lo``/``pair_hi``/``pair_hist`` (the non-zero history rows,
    sorted by key), ``force_lo``/``force_hi``/``pair_force`` (fn, ftx, fty of every touching
    pair) and ``ring_force`` [n,3] (of each particle's ring contact), and the attributes."""
    ps, n_owned, d = sim.ps, int(sim.clock.n_owned[0]), sim.decomp
    rows = slice(0, int(sim.clock.n_local[0]) if d.rank == 0 else n_owned)
    mine = {k: getattr(ps, k)[rows] for k in ARRAYS if k != "hist_wall" or sim.hist}
    ring = np.zeros((ps.gid.size, 3))
    tables = sim.local_tables(n_owned)
    t_ring = tables.rings
    if t_ring is not None:
        ring[t_ring["index"], 0] = t_ring["normal_force"]
        ring[t_ring["index"], 1:] = t_ring["tangential_force"]
    mine["ring_force"] = ring[rows]
    arrays = d.gather_rows(mine)
    t = tables.pairs
    forces = d.gather_rows({"key": t["ids"], "force": np.column_stack(
        [t["normal_force"], t["tangential_force"]])}, key="key")
    history = sim.history_table() if sim.hist else None
    if sim.hist and d.parallel:
        gathered = d.gather_rows({"key": np.column_stack(history[:2]), "hist": history[2]},
                                 key="key")
        history = None if gathered is None else merge_history(
            *np.ascontiguousarray(gathered["key"].T), gathered["hist"],
            np.zeros((0, 2 + sim.hist)))
    if arrays is None:
        return None
    walls = arrays["kind"] != FREE  # prescribed: their loads are not state (each rank adds
    arrays["f"][walls] = 0.0        # only its own particles' contacts to them)
    arrays["tau"][walls] = 0.0
    if not sim.hist:
        arrays["hist_wall"] = np.zeros((0, 2))
    empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)))
    arrays["pair_lo"], arrays["pair_hi"], arrays["pair_hist"] = history or empty
    arrays["force_lo"], arrays["force_hi"] = np.ascontiguousarray(forces["key"].T)
    arrays["pair_force"] = forces["force"]
    attrs = {"step": int(sim.clock.step[0]), "time": sim.time, "dt": sim.dt,
             "ring_angle": sim.prm.rings.omega_in * sim.clock_time,
             "fingerprint": sim.scene.fingerprint(), "n_free": sim.n_free, "ranks": d.size,
             "scene_physics": json.dumps(sim.scene.physics(), sort_keys=True),
             "history_columns": ",".join(sim.history_columns)}
    if sim.rings is not None:
        rings, layout = checkpoint_part(sim.rings, sim.scene)
        arrays.update(rings)
        attrs.update(layout)
    return arrays, attrs


def restore(path, ps, scene, dt: float, columns: tuple[str, ...], decomp, log):
    """Fill the whole-cell arrays ``ps`` (gid order) from the checkpoint at ``path`` (read on
    rank 0, sent to all). Returns ``(step, history, forces)``: the step to continue from, the
    history table (lo, hi, rows with this run's ``columns``; None without history) and the
    recorded forces ``(lo, hi, [m,3] pair forces, [n,3] ring forces)`` and the ring samples
    (averages.ARRAYS and the attribute ``rings_layout``, where the checkpoint has them; for
    ``averages.resume``). SceneError if the checkpoint belongs to another scene or is damaged."""
    arrays, attrs = decomp.bcast_call(load_checkpoint, path)
    if attrs["fingerprint"] != scene.fingerprint():
        differ = (physics_differences(scene.physics(), json.loads(attrs["scene_physics"]))
                  if "scene_physics" in attrs else [])
        raise SceneError(f"--restart {path}: the checkpoint belongs to a different scene: "
                         + ("; ".join(differ[:5]) + (" ..." if len(differ) > 5 else "")
                            if differ else "geometry, particles, contact law, effects or dt "
                            "differ (a checkpoint of an older pardem does not say which)"))
    if attrs["dt"] != dt:
        raise SceneError(f"--restart {path}: checkpoint dt = {attrs['dt']} s differs from "
                         f"the scene's dt = {dt} s")
    n = ps.gid.size
    if arrays["gid"].size != n:
        raise SceneError(f"--restart {path}: {arrays['gid'].size} particles in the "
                         f"checkpoint, {n} in the scene")
    _check_restored(path, arrays, ps)
    written = attrs["history_columns"]
    for k in ("hist_wall", "pair_hist"):
        arrays[k] = _history_columns(path, arrays[k], written, columns, log)
    for k in ARRAYS:
        if columns or k != "hist_wall":
            getattr(ps, k)[: arrays[k].shape[0]] = arrays[k]
    history = ((arrays["pair_lo"], arrays["pair_hi"], arrays["pair_hist"]) if columns
               else None)
    forces = (arrays["force_lo"], arrays["force_hi"], arrays["pair_force"],
              arrays["ring_force"])
    averages = {k: arrays[k] for k in AVERAGE_ARRAYS if k in arrays}
    if "rings_layout" in attrs:
        averages["rings_layout"] = str(attrs["rings_layout"])
    return int(attrs["step"]), history, forces, averages


def _history_columns(path, rows: np.ndarray, written: tuple[str, ...],
                     columns: tuple[str, ...], log) -> np.ndarray:
    """A checkpoint's history rows (columns ``written``) with this run's ``columns``. A column
    the checkpoint lacks starts at zero, except eta, which starts as the spring: exact for
    every contact that has not slid since it began (logged)."""
    rows = np.asarray(rows, float)
    if rows.ndim != 2 or (rows.shape[0] and rows.shape[1] != len(written)):
        raise SceneError(f"--restart {path}: corrupted checkpoint: contact history of shape "
                         f"{rows.shape} (rows x {len(written)} expected: {', '.join(written)})")
    out = np.zeros((rows.shape[0], len(columns)))
    for c, name in enumerate(columns):
        if name in written:
            out[:, c] = rows[:, written.index(name)]
        elif name.startswith("eta_") and f"spring_{name[-1]}" in written:
            out[:, c] = rows[:, written.index(f"spring_{name[-1]}")]
    if "eta_x" in columns and "eta_x" not in written and rows.shape[0]:
        log(f"restart from {path}: the checkpoint has no eta (total tangential displacement); "
            "it starts from the spring, exact for contacts that have not slid")
    return out


def _check_restored(path, arrays: dict[str, np.ndarray], ps) -> None:
    """A checkpoint whose bytes were damaged may still read as HDF5 (it has no checksums): its
    particles must be the scene's (ids, kinds, radii, masses, the wall disks' places on their
    rings: bit for bit) and every state value finite, else the restart is refused instead of
    continuing from garbage."""
    # e0 = (cos, sin) phi0 may differ by an ulp between numpy builds: a checkpoint moves
    for key, tol in (("gid", 0), ("kind", 0), ("radius", 0), ("mass", 0), ("phi0", 0),
                     ("e0", 1e-12)):  # phi0, e0: the wall disks' places on their rings
        got, want = np.asarray(arrays[key]), getattr(ps, key)  # masses of wall disks: inf
        differ = got != want if tol == 0 else ~(np.abs(got - want) <= tol)  # NaN differs
        bad = np.flatnonzero(differ.reshape(differ.shape[0], -1).any(axis=1))
        if bad.size:
            raise SceneError(f"--restart {path}: corrupted checkpoint: {key} of particle row "
                             f"{int(bad[0])} is {arrays[key][bad[0]]!r}, the scene has "
                             f"{getattr(ps, key)[bad[0]]!r}")
    for key in ("x", "v", "theta", "omega", "f", "tau", "hist_wall", "pair_hist", "pair_force",
                "ring_force"):
        bad = np.flatnonzero(~np.isfinite(np.asarray(arrays[key], float)).reshape(
            len(arrays[key]), -1).all(axis=1)) if len(arrays[key]) else []
        if len(bad):
            raise SceneError(f"--restart {path}: corrupted checkpoint: non-finite {key} in row "
                             f"{int(bad[0])}")
    for lo_key, hi_key in (("pair_lo", "pair_hi"), ("force_lo", "force_hi")):
        lo, hi = np.asarray(arrays[lo_key]), np.asarray(arrays[hi_key])
        if lo.size and not (np.all(lo < hi) and lo.min() >= 0 and hi.max() < ps.gid.size):
            raise SceneError(f"--restart {path}: corrupted checkpoint: {lo_key}/{hi_key} are "
                             f"not pairs of particle ids 0..{ps.gid.size - 1}")

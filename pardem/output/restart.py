"""What a checkpoint holds and how a run continues from one: the whole state gathered on rank 0
(``gather_state``), and each rank's share of it read back by that rank (``restore``).

Stage: output / restart. The file format itself is ``checkpoint.py``. A checkpoint holds every
particle array, the contact history keyed by gid pairs (its columns named, so a run that tracks
more or fewer columns than the one that wrote it can continue), and the forces the last step
applied to every touching pair and ring contact (so output right after a restart reports them
exactly), and the ring samples taken so far (``averages.py``). A restarted run continues bit for
bit, on any number of ranks, and so do its averages.
"""

from __future__ import annotations

import json
from typing import NamedTuple

import numpy as np

from ..contact.history import carry_history, merge_history
from ..input.placement import cell_rows, share_rows
from ..input.scene import SceneError
from ..core.state import FREE, Particles
from .averages import ARRAYS as AVERAGE_ARRAYS
from .averages import checkpoint_part
from .checkpoint import ARRAYS, LATER_ARRAYS, checkpoint_file, open_checkpoint


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
             "ring_angle": sim.prm.rings.omega_in * sim.clock_time + sim.prm.rings.phase_in,
             "ring_phase": sim.prm.rings.phase_in,
             "fingerprint": sim.scene.fingerprint(), "n_free": sim.n_free, "ranks": d.size,
             "scene_physics": json.dumps(sim.scene.physics(), sort_keys=True),
             "history_columns": ",".join(sim.history_columns),
             "end_snapshot": int(sim.end_snapshot)}
    if sim.rings is not None:
        rings, layout = checkpoint_part(sim.rings, sim.scene)
        arrays.update(rings)
        attrs.update(layout)
    return arrays, attrs


CHUNK_ROWS = 1 << 16  # rows read at a time: a rank holds its share of a checkpoint, not all


class Restored(NamedTuple):
    """A rank's share of a checkpoint: its particle arrays (``placement.share_rows``' rows and
    capacity), how many rows are free and owned and how many there are, the step to continue
    from, the history of the pairs that touch its rows (lo, hi, rows with the run's columns;
    None without history), the recorded forces ``(lo, hi, [m,3] pair forces, gids, [k,3] ring
    forces of those gids)``, the ring samples (averages.ARRAYS and the attribute
    ``rings_layout``, where the checkpoint has them; for ``averages.resume``), and whether the
    snapshot of its state is an end snapshot off the grid (``series.py``; False in files of
    pardem before it said), and the inner ring's phase (``walls.Rings.phase_in``) with, for a
    branch, whether its physics is the prepared run's (``branch.py``: ``exact``)."""

    ps: Particles
    n_owned: int
    n_rows: int
    step: int
    history: tuple | None
    forces: tuple
    averages: dict
    end_snapshot: bool
    phase: float = 0.0
    exact: bool = True


def restore(path, init, scene, dt: float, columns: tuple[str, ...], decomp, log,
            head_of=None) -> Restored:
    """This rank's share of the checkpoint at ``path`` (collective). Rank 0 checks that it
    belongs to the scene and reads the free particles' positions, from which the annulus is
    cut, and the ring samples; then each rank reads its own rows of every particle array and
    the pairs that touch them, ``CHUNK_ROWS`` rows at a time, so that no rank ever holds the
    whole cell. SceneError on every rank if the checkpoint belongs to another scene or is
    damaged. ``head_of``: rank 0's checks (``_head``'s arguments; a branch's:
    ``branch.branch_head``)."""
    head = decomp.bcast_call(head_of or _head, path, scene, dt, init, columns)
    if head.pop("no_eta"):
        log(f"restart from {path}: the checkpoint has no eta (total tangential displacement); "
            "it starts from the spring, exact for contacts that have not slid")
    idx, n_owned, capacity = share_rows(init.radius.size, head.pop("x_free"), decomp)
    ps = cell_rows(init, len(columns), idx, capacity)
    message = None
    try:
        history, forces = _read_share(head["file"], ps, idx, columns)
    except SceneError as e:  # said on every rank, below: no rank waits for the others
        message = str(e)
    message = decomp.first_message(message)
    if message is not None:
        raise SceneError(message)
    return Restored(ps, n_owned, idx.size, head["step"], history if columns else None, forces,
                    head["averages"], head["end_snapshot"], **head["branch"])


def _head(path, scene, dt: float, init, columns: tuple[str, ...]) -> dict:
    """Rank 0's part of ``restore``: the checks against the scene, the file, the step, the free
    particles' positions, the ring samples, and whether the missing eta is to be said."""
    with open_checkpoint(path) as (arrays, attrs):
        if attrs["fingerprint"] != scene.fingerprint():
            differ = (physics_differences(scene.physics(), attrs["scene_physics"])
                      if "scene_physics" in attrs else [])
            raise SceneError(
                f"--restart {path}: the checkpoint belongs to a different scene: "
                + ("; ".join(differ[:5]) + (" ..." if len(differ) > 5 else "") if differ
                   else "geometry, particles, contact law, effects or dt differ (a "
                   "checkpoint of an older pardem does not say which)"))
        if attrs["dt"] != dt:
            raise SceneError(f"--restart {path}: checkpoint dt = {attrs['dt']} s differs "
                             f"from the scene's dt = {dt} s")
        n = init.radius.size
        if arrays["gid"].shape[0] != n:
            raise SceneError(f"--restart {path}: {arrays['gid'].shape[0]} particles in the "
                             f"checkpoint, {n} in the scene")
        x_free = np.asarray(arrays["x"][:init.n_free], float)
        bad = np.flatnonzero(~np.isfinite(x_free).all(axis=1))
        if bad.size:  # the cut is placed from these: checked before any rank reads its share
            raise SceneError(f"--restart {path}: corrupted checkpoint: non-finite x in row "
                             f"{int(bad[0])}")
        averages = {k: arrays[k][()] for k in AVERAGE_ARRAYS if k in arrays}
        if "rings_layout" in attrs:
            averages["rings_layout"] = str(attrs["rings_layout"])
        written = attrs["history_columns"]
        no_eta = ("eta_x" in columns and "eta_x" not in written
                  and (arrays["pair_hist"].shape[0] or arrays["hist_wall"].shape[0]) > 0)
        return {"file": checkpoint_file(path), "step": int(attrs["step"]), "x_free": x_free,
                "averages": averages, "no_eta": no_eta,
                "end_snapshot": bool(attrs.get("end_snapshot", False)),
                "branch": {"phase": float(attrs.get("ring_phase", 0.0))}}


def _read_share(path, ps, idx: np.ndarray, columns: tuple[str, ...]):
    """Rows ``idx`` (gids, ascending) of the checkpoint's particle arrays into ``ps`` (which
    holds the scene's values of those rows, checked against the file's), the history and the
    recorded forces of the pairs with a particle among them. Returns ``(history, forces)``."""
    with open_checkpoint(path, verify=False) as (arrays, attrs):  # rank 0 verified it
        k = idx.size
        for key in ARRAYS:
            if key == "hist_wall" or key in LATER_ARRAYS and key not in arrays:
                continue  # a later array missing: the scene's (cell_rows) stand
            rows = _rows(arrays[key], idx)
            _check_rows(path, key, rows, getattr(ps, key)[:k], idx)
            getattr(ps, key)[:k] = rows
        written = attrs["history_columns"]
        if arrays["hist_wall"].shape[0]:
            rows = _rows(arrays["hist_wall"], idx)
            _check_rows(path, "hist_wall", rows, None, idx)
            if columns:
                ps.hist_wall[:k] = _history_columns(path, rows, written, columns)
        ring = _rows(arrays["ring_force"], idx)
        _check_rows(path, "ring_force", ring, None, idx)
        touched = np.zeros(arrays["gid"].shape[0], np.bool_)
        touched[idx] = True
        lo, hi, hist = _pairs(path, arrays, "pair_lo", "pair_hi", "pair_hist", touched)
        history = (lo, hi, _history_columns(path, hist, written, columns))
        forces = _pairs(path, arrays, "force_lo", "force_hi", "pair_force", touched)
        return history, forces + (idx, ring)


def _rows(dataset, idx: np.ndarray) -> np.ndarray:
    """Rows ``idx`` (ascending) of an HDF5 dataset (or array), read a chunk at a time."""
    out = np.empty((idx.size,) + tuple(dataset.shape[1:]), dataset.dtype)
    for a in range(0, dataset.shape[0], CHUNK_ROWS):
        lo, hi = np.searchsorted(idx, (a, a + CHUNK_ROWS))
        if hi > lo:
            block = dataset[a:int(idx[hi - 1]) + 1]
            out[lo:hi] = block[idx[lo:hi] - a]
    return out


def _pairs(path, arrays, lo_key: str, hi_key: str, value_key: str, touched: np.ndarray):
    """The rows of a pair table (keys ``lo_key``/``hi_key``, values ``value_key``) with a
    particle among ``touched``, read and checked a chunk at a time."""
    n, m = touched.size, arrays[lo_key].shape[0]
    values = arrays[value_key]
    width = values.shape[1] if values.ndim == 2 else 0
    keep: list[tuple] = []
    for a in range(0, m, CHUNK_ROWS):
        lo, hi = np.asarray(arrays[lo_key][a:a + CHUNK_ROWS]), arrays[hi_key][a:a + CHUNK_ROWS]
        if not (np.all(lo < hi) and lo.min() >= 0 and hi.max() < n):
            raise SceneError(f"--restart {path}: corrupted checkpoint: {lo_key}/{hi_key} are "
                             f"not pairs of particle ids 0..{n - 1}")
        v = np.asarray(values[a:a + CHUNK_ROWS], float) if values.shape[0] else None
        if v is not None:
            _check_rows(path, value_key, v, None, np.arange(a, a + v.shape[0]))
        mine = touched[lo] | touched[hi]
        keep.append((lo[mine], hi[mine], v[mine] if v is not None else np.zeros((0, width))))
    if not keep:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, width))
    return tuple(np.concatenate(part) for part in zip(*keep))


def _check_rows(path, key: str, got: np.ndarray, want: np.ndarray | None, rows) -> None:
    """A checkpoint whose bytes were damaged may still read as HDF5 (one of an earlier pardem,
    without checksums, or a change that kept its checksums consistent): the
    particles must be the scene's (ids, kinds, radii, masses, the wall disks' places on their
    rings: ``want``, bit for bit) and every state value finite, else the restart is refused
    instead of continuing from garbage. ``rows``: the file's row of each row of ``got``."""
    if key in IDENTITY:
        tol = IDENTITY[key]
        differ = got != want if tol == 0 else ~(np.abs(got - want) <= tol)  # NaN differs
        bad = np.flatnonzero(differ.reshape(differ.shape[0], -1).any(axis=1))
        if bad.size:
            raise SceneError(f"--restart {path}: corrupted checkpoint: {key} of particle row "
                             f"{int(rows[bad[0]])} is {got[bad[0]].tolist()}, the scene has "
                             f"{want[bad[0]].tolist()}")
    elif key in FINITE and len(got):
        bad = np.flatnonzero(~np.isfinite(np.asarray(got, float)).reshape(
            len(got), -1).all(axis=1))
        if bad.size:
            raise SceneError(f"--restart {path}: corrupted checkpoint: non-finite {key} in row "
                             f"{int(rows[bad[0]])}")


# e0 = (cos, sin) phi0 may differ by an ulp between numpy builds: a checkpoint moves; masses
# of wall disks are inf; phi0 and e0 are the wall disks' places on their rings
IDENTITY = {"gid": 0, "kind": 0, "species": 0, "radius": 0, "mass": 0, "phi0": 0, "e0": 1e-12}
FINITE = ("x", "v", "theta", "omega", "f", "tau", "hist_wall", "pair_hist", "pair_force",
          "ring_force")


def _history_columns(path, rows: np.ndarray, written: tuple[str, ...],
                     columns: tuple[str, ...]) -> np.ndarray:
    """A checkpoint's history rows (columns ``written``) with this run's ``columns``. A column
    the checkpoint lacks starts at zero, except eta, which starts as the spring: exact for
    every contact that has not slid since it began (``restore`` says so)."""
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
    return out


def put_recorded_forces(sim, lo, hi, pair_force, ring_gid, ring_force) -> None:
    """A checkpoint's applied forces into the new lists (output right after a restart):
    pairs by key, ring contacts by gid (``ring_gid`` ascending)."""
    count, pairs, gid = int(sim.pairs.count[0]), sim.pairs, sim.ps.gid
    force = np.ascontiguousarray(pair_force, float).reshape(-1, 3)  # (fn, ftx, fty)
    # straight into fn and ft: a (count, 3) table first was the set-up's peak at 1M disks
    carry_history(lo, hi, force, gid, pairs.i, pairs.j, pairs.fn[:count].reshape(-1, 1))
    carry_history(lo, hi, force, gid, pairs.i, pairs.j, pairs.ft[:count], 1)
    q = pairs.wall[:pairs.wall_count[0]]
    ring = np.asarray(ring_force, float)[np.searchsorted(ring_gid, sim.ps.gid[q])]
    pairs.wall_fn[:q.size], pairs.wall_ft[:q.size] = ring[:, 0], ring[:, 1:]


def physics_differences(ours: dict, theirs: dict) -> list[str]:
    """``[table] key: theirs -> ours`` for every key where two ``Scene.physics()`` differ
    (lists of tables, such as [[species]] and [[particles]], compared whole)."""
    out = []
    for table in sorted(set(ours) | set(theirs)):
        a, b = ours.get(table), theirs.get(table)
        if isinstance(a, dict) and isinstance(b, dict):
            out += [f"[{table}] {k}: {b.get(k, '(absent)')!r} in the checkpoint, "
                    f"{a.get(k, '(absent)')!r} here"
                    for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
        elif a != b:
            out.append(f"[[{table}]] differ" if isinstance(a or b, list) else f"[{table}] differs")
    return out

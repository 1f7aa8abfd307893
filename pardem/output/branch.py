"""Branching runs: a new run from a prepared state (``pardem run NEW.toml --from RUN``) with
other material or drive, where ``--restart`` is the exact continuation of the same scene.

Stage: output / restart (rank 0's half of ``restart.restore`` for a branch; the builder puts
the rest together). What a branch keeps: positions, velocities, spins and angles, the time, the
inner ring's angle, and the contact history column by column where the new law keeps a column
of that name (``contact.model.history_columns``). What may change: every key of ``BRANCHABLE``
(and [output], [averaging], [time] end, [scene] name, which no checkpoint binds). Everything
else (the particles, the geometry) must be the prepared run's, and a branch that differs is
refused naming the key and both values.

The time: a branch whose step differs from the prepared run's (k_n sets t_c, and so dt) starts
at the step of the new dt nearest the prepared time, said in the log when it is not exact. The
ring angle: the angle the inner ring turned through (omega t + phase) is kept by a new phase
(``walls.Rings.phase_in``) when omega_inner changes. The forces at the branch's first state
are the new law's (the builder computes them without advancing the springs), unless the
physics is the prepared run's, bit for bit: then the checkpoint's applied forces are kept and
the branch continues exactly as ``--restart`` would.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from ..input.scene import _LATER, Contact, SceneError
from ..input.species import disk_mass
from .averages import sample_grid
from .checkpoint import checkpoint_file, open_checkpoint

BRANCHABLE = {"contact": None, "effects": None, "neighbors": None,
              "time": ("dt", "dt_per_contact", "integrator"), "geometry": ("omega_inner",)}
"""Tables (None: every key) and keys of ``Scene.physics()`` a branch may change."""

RESETS = {"spring": ("tangential springs", "tangential friction"),
          "rolling": ("rolling springs", "rolling resistance")}
"""History columns by prefix: what they are, and the effect that keeps them."""


def branch_head(path, scene, dt: float, init, columns: tuple[str, ...], step_length: Fraction,
                log) -> dict:
    """Rank 0's part of a branch from the checkpoint at ``path`` (a file or a run folder):
    the checks against the prepared run, the file, the step to start from, the free particles'
    positions; ``phase`` (the inner ring's new phase, rad) and ``exact`` (the physics is the
    prepared run's: its forces are kept) for the builder. Logs what the history loses."""
    with open_checkpoint(path) as (arrays, attrs):
        if "scene_physics" not in attrs:
            raise SceneError(f"--from {path}: the checkpoint does not record its scene (written "
                             "by an older pardem): continue it with --restart instead")
        theirs = attrs["scene_physics"]
        ours = scene.physics()
        refuse_changes(path, ours, theirs, init.n_free, int(attrs.get("n_free", init.n_free)))
        n = init.radius.size
        if arrays["gid"].shape[0] != n:  # the wall disks: a layout the checks above missed
            raise SceneError(f"--from {path}: {arrays['gid'].shape[0]} particles and wall "
                             f"disks in the prepared run, {n} here")
        t = float(attrs["time"])
        if not scene.time.end > t:
            raise SceneError(f"[time] end = {scene.time.end:.6g} s does not lie after the "
                             f"prepared state's time {t:.6g} s (--from {path}): a branch runs on "
                             "from that time; give a later end")
        exact = attrs["fingerprint"] == scene.fingerprint() and attrs["dt"] == dt
        step = int(attrs["step"]) if attrs["dt"] == dt else branch_step(t, step_length, log)
        omega = scene.geometry.omega_inner if scene.geometry is not None else 0.0
        same_turn = step == int(attrs["step"]) and omega == _omega(theirs)
        phase = (float(attrs.get("ring_phase", 0.0)) if same_turn
                 else float(attrs.get("ring_angle", 0.0)) - omega * (step * dt))
        if scene.averaging is not None and step > 0:
            before = sample_grid(scene, dt, step - 1)
            if before.size:
                raise SceneError(
                    f"[averaging] start = {scene.averaging.start:.6g} s lies before the "
                    f"prepared state's time {t:.6g} s (--from {path}): a branch averages "
                    "only its own samples; set start to that time or later")
        said_resets(attrs["history_columns"], columns, log)
        x_free = np.asarray(arrays["x"][:init.n_free], float)
        if not np.isfinite(x_free).all():
            raise SceneError(f"--from {path}: corrupted checkpoint: non-finite positions")
        log(f"branch from {checkpoint_file(path)} at t = {step * float(step_length):.6g} s"
            + ("" if exact else "; changed: " + ("; ".join(
                _changes(with_defaults(ours), with_defaults(theirs))) or "dt")))
        return {"file": checkpoint_file(path), "step": step, "x_free": x_free,
                "averages": {}, "no_eta": False, "end_snapshot": False,
                "branch": {"phase": phase, "exact": exact}}


def refuse_changes(path, ours: dict, theirs: dict, n_free: int, n_prepared: int) -> None:
    """SceneError naming the first key outside ``BRANCHABLE`` whose value differs between this
    scene's ``physics()`` (``ours``) and the prepared run's (``theirs``), with both values."""
    ours, theirs = (with_masses(with_defaults(d)) for d in (ours, theirs))
    if n_free != n_prepared:
        raise SceneError(f"--from {path}: {n_prepared} free particles in the prepared run, "
                         f"{n_free} here; a branch keeps the prepared particles")
    for table in sorted(set(ours) | set(theirs)):
        keys = BRANCHABLE.get(table, ())
        if keys is None:
            continue
        a, b = ours.get(table), theirs.get(table)
        if isinstance(a, dict) or isinstance(b, dict):
            a, b = a or {}, b or {}
            for k in sorted(set(a) | set(b)):
                if k not in keys and a.get(k) != b.get(k):
                    _refuse(path, f"[{table}] {k}", b.get(k, "(absent)"), a.get(k, "(absent)"))
        elif table == "particles":  # free scenes: the initial positions are the checkpoint's
            for i, (p, q) in enumerate(zip(a, b)):
                for k in ("diameter", "mass"):
                    if p[k] != q[k]:
                        _refuse(path, f"[[particles]] #{i} {k}", q[k], p[k])
        elif a != b:
            for i, (p, q) in enumerate(zip(a or [], b or [])):
                for k in sorted(set(p) | set(q)):
                    if p.get(k) != q.get(k):
                        how = (" (given, or density pi (d/2)^2 h with the [contact] height)"
                               if table == "species" and k == "mass" else "")
                        _refuse(path, f"[[{table}]] #{i} ({q.get('name', i)}) {k}{how}",
                                q.get(k, "(absent)"), p.get(k, "(absent)"))
            _refuse(path, f"[[{table}]] entries", len(b or []), len(a or []))


def _refuse(path, key: str, theirs, ours) -> None:
    raise SceneError(f"--from {path}: {key} is {theirs!r} in the prepared run, {ours!r} here; "
                     "a branch keeps the prepared particles and geometry (it may change "
                     "[contact], [effects], [time] dt, dt_per_contact and integrator, "
                     "[geometry] omega_inner, [neighbors], [output] and [averaging])")


def branch_step(t: float, step_length: Fraction, log) -> int:
    """The step of length ``step_length`` (s) nearest the prepared time ``t`` (s), said in the
    log when the time moves (the new dt does not divide it)."""
    exact = Fraction(repr(t)) / step_length  # the time as written: 0.15 is 3/20
    step = round(exact)
    if step != exact:
        log(f"branch: the prepared time {t:.9g} s is not a whole number of steps of the new "
            f"dt = {float(step_length):.6g} s; the branch starts at the nearest step, "
            f"t = {float(step * step_length):.9g} s")
    return int(step)


def said_resets(written: tuple[str, ...], columns: tuple[str, ...], log) -> None:
    """Log each kind of contact history the branch cannot carry over: reset (this run keeps
    it, the prepared run did not) or dropped (the other way round)."""
    for prefix, (what, effect) in RESETS.items():
        here = any(c.startswith(prefix) for c in columns)
        there = any(c.startswith(prefix) for c in written)
        if here and not there:
            log(f"{what} reset: {effect} is off in the prepared run; every contact's starts "
                "at zero")
        elif there and not here:
            log(f"{what} dropped: {effect} is off in this branch")
    def normal(names):
        return [c for c in names if not c.startswith(("spring", "rolling", "eta"))]

    missing = [c for c in normal(columns) if c not in written]
    if missing:
        log(f"normal-law history ({', '.join(missing)}) reset: the prepared run's normal law "
            "keeps none; every contact's starts from zero")
    dropped = [c for c in normal(written) if c not in columns]
    if dropped:
        log(f"normal-law history ({', '.join(dropped)}) dropped: this branch's normal law "
            "keeps none")
    if "eta_x" in columns and "eta_x" not in written and "spring_x" in written:
        log("eta (total tangential displacement) starts as the spring: the prepared run did "
            "not track it (exact for contacts that have not slid)")


def _omega(physics: dict) -> float:
    return float(physics.get("geometry", {}).get("omega_inner", 0.0))


def _changes(ours: dict, theirs: dict) -> list[str]:
    """``[table] key: old -> new`` for the keys that differ (the branch's log line)."""
    out = []
    for table in sorted(BRANCHABLE):
        a, b = ours.get(table) or {}, theirs.get(table) or {}
        out += [f"[{table}] {k}: {b.get(k, '(absent)')!r} -> {a.get(k, '(absent)')!r}"
                for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    return out


def with_masses(physics: dict) -> dict:
    """A ``Scene.physics()`` dict whose [[species]] rows give the disks' masses, however the
    scene wrote them: a fixed diameter's mass as given or from its density (species.disk_mass
    with the [contact] height, the same bits as the run's), so that a branch may give the
    prepared run's disks by density where it gave masses (or the other way round) and is
    refused where the masses differ; a distribution's disks get theirs from the density and
    the height, which then both must be the prepared run's."""
    if not physics.get("species"):
        return physics
    height = physics.get("contact", {}).get("height", Contact().height)
    rows = []
    for row in physics["species"]:
        row = dict(row)
        if "diameter" in row and "density" in row:
            row["mass"] = disk_mass(row.pop("density"), row["diameter"], height)
        elif "density" in row:
            row["[contact] height"] = height
        rows.append(row)
    return {**physics, "species": rows}


def with_defaults(physics: dict) -> dict:
    """A ``Scene.physics()`` dict with the keys it leaves out at their default (``_LATER``)
    put back, so that two compare key by key."""
    d = {t: dict(v) if isinstance(v, dict) else v for t, v in physics.items()}
    for (table, key), default in _LATER.items():
        if isinstance(d.get(table), dict):
            d[table].setdefault(key, default)
    return d

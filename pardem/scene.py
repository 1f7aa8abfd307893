"""Scene description: the validated input of a pardem run.

Stage: input. ``load_scene`` reads a TOML scene file (layout and key names fixed by SPEC §7) and
returns a ``Scene`` made of frozen, validated dataclasses; nothing downstream re-checks them.
Every problem raises ``SceneError`` with one message naming the offending ``[table] key``.
``scene_to_toml`` / ``write_scene`` write a scene back (the resolved scene stored with a run).
Units are SI throughout: m, kg, s, rad, N.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import numbers
import os
import tomllib
from dataclasses import MISSING, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np


class SceneError(ValueError):
    """An invalid scene; the message names the table and key at fault."""


@dataclass(frozen=True)
class SceneInfo:
    """``[scene]``: name (default: file stem, else "scene"), kind ("couette" | "free"),
    seed (int >= 0, default 1; placement randomness is a function of seed and particle id)."""

    name: str
    kind: str
    seed: int = 1


@dataclass(frozen=True)
class Geometry:
    """``[geometry]`` (couette only): inner_radius (m, 0.1035), outer_radius (m, final, 0.2525),
    outer_start_radius (m, at t = 0, 0.33), compression_time (s, 2.0), omega_inner (rad/s,
    counter-clockwise positive, 0.1), wall_particle_diameter (m, 2.5e-3),
    wall_particle_spacing (m, centre to centre along a ring, 7.0e-3).

    The wall layout of each ring (prefix ``inner_`` or ``outer_``; walls.WallLayout):
    ``*_wall_count`` (glued disks on that ring, >= 0, 0 = a smooth ring; "auto" = None:
    round(2 pi R / wall_particle_spacing), at least 1), ``*_wall_diameter`` (m, "auto" = None:
    wall_particle_diameter), ``*_flat_surface`` (true: the flat ring surface behind the
    disks is a contact surface too; false: only the disks are). Disks may overlap (spacing
    below their diameter). The outer ring's disks sit on its final radius's spacing and move
    radially with it during the compression."""

    inner_radius: float = 0.1035
    outer_radius: float = 0.2525
    outer_start_radius: float = 0.33
    compression_time: float = 2.0
    omega_inner: float = 0.1
    wall_particle_diameter: float = 2.5e-3
    wall_particle_spacing: float = 7.0e-3
    inner_wall_count: int | None = None
    outer_wall_count: int | None = None
    inner_wall_diameter: float | None = None
    outer_wall_diameter: float | None = None
    inner_flat_surface: bool = True
    outer_flat_surface: bool = True


@dataclass(frozen=True)
class Species:
    """``[[species]]`` (couette only): name (unique), diameter (m), mass (kg), count (>= 0);
    all required."""

    name: str
    diameter: float
    mass: float
    count: int


_PCOLS = ("x", "y", "vx", "vy", "omega", "diameter", "mass")
_PUNITS = {"x": "m", "y": "m", "vx": "m/s", "vy": "m/s", "omega": "rad/s", "diameter": "m",
           "mass": "kg"}


@dataclass(frozen=True, eq=False)
class FreeParticles:
    """Free-scene particles, row i = particle id i: read-only float64 arrays x, y (m, required),
    vx, vy (m/s, default 0), omega (rad/s, default 0), diameter (m, required), mass (kg,
    required). All of one length N >= 1."""

    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    omega: np.ndarray
    diameter: np.ndarray
    mass: np.ndarray

    def __post_init__(self) -> None:
        for k in _PCOLS:
            a = np.array(getattr(self, k), dtype=np.float64)
            a.setflags(write=False)
            object.__setattr__(self, k, a)

    def __len__(self) -> int:
        return int(self.x.size)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, FreeParticles):
            return NotImplemented
        return all(np.array_equal(getattr(self, k), getattr(other, k)) for k in _PCOLS)

    def __hash__(self) -> int:
        return hash(tuple(getattr(self, k).tobytes() for k in _PCOLS))


@dataclass(frozen=True)
class Contact:
    """``[contact]``: k_n (N/m, 352.1), gamma_n (kg/s, 0.19), k_t (N/m, 267.1), mu (0.44),
    mu_bottom (2e-5), gravity (m/s^2, 9.81; bottom friction only), height (m, disk height h,
    6e-3)."""

    k_n: float = 352.1
    gamma_n: float = 0.19
    k_t: float = 267.1
    mu: float = 0.44
    mu_bottom: float = 2e-5
    gravity: float = 9.81
    height: float = 6e-3


@dataclass(frozen=True)
class Effects:
    """``[effects]`` (booleans, same defaults for both kinds): normal_damping (true),
    tangential_friction (true), rotation (true), bottom_friction (true),
    clip_attractive_normal (false)."""

    normal_damping: bool = True
    tangential_friction: bool = True
    rotation: bool = True
    bottom_friction: bool = True
    clip_attractive_normal: bool = False


@dataclass(frozen=True)
class TimeCfg:
    """``[time]``: dt (s, or "auto" = None: t_c(smallest pair) / dt_per_contact; default auto),
    dt_per_contact (>= 5, default 50), end (s, 239.0), integrator ("verlet": velocity Verlet
    whose velocity-dependent forces use the velocity predicted at the new step, v + dt/2 a,
    with the damping of a contact that starts or ends within a step weighted by its in-contact
    fraction (default); "verlet-halfstep": plain velocity Verlet with the half-step velocity
    in those forces and no weighting, as in LAMMPS GRANULAR; docs/accuracy.md compares them)."""

    dt: float | None = None
    dt_per_contact: float = 50.0
    end: float = 239.0
    integrator: str = "verlet"


@dataclass(frozen=True)
class Neighbors:
    """``[neighbors]`` (optional): skin (m, Verlet-list skin; "auto" = None, meaning 0.1 x the
    smallest free-particle diameter; default auto)."""

    skin: float | None = None


@dataclass(frozen=True)
class OutputCfg:
    """``[output]``: snapshot_interval (s, 1.0), checkpoint_interval (s, 10.0), contacts (write
    force-chain contacts with snapshots, true)."""

    snapshot_interval: float = 1.0
    checkpoint_interval: float = 10.0
    contacts: bool = True


@dataclass(frozen=True)
class AveragingCfg:
    """``[averaging]`` (optional; in-situ ring averaging): start (s, 180.0), end (s, 239.0),
    sample_interval (s, 0.1), ring_width (m, 0.9275e-3 = d_small/8), weighting ("slice" (the
    paper's) | "exact" | "centre" | "gaussian", see averaging/weights.py; default "slice"),
    reference_diameter (m, the d~ of r~ = (r - R_i)/d~ and of the
    v_phi decay length; "auto" = None: the mean free-particle diameter; the paper's scenes
    set 8.0e-3), displacement ("eta": the tangential part of the contact displacement Delta in
    eps and kappa is the paper's total tangential displacement eta of eq. 1.3, which keeps
    growing while a contact slides (default); "spring": the Cundall-Strack spring xi, capped
    at the Coulomb limit, with which M = (k_t/pi h) kappa . F holds identically and mu_c only
    restates the fabric)."""

    start: float = 180.0
    end: float = 239.0
    sample_interval: float = 0.1
    ring_width: float = 0.9275e-3
    weighting: str = "slice"
    reference_diameter: float | None = None
    displacement: str = "eta"


@dataclass(frozen=True)
class Scene:
    """A complete validated scene. ``geometry`` and ``species`` are set for couette scenes,
    ``particles`` for free ones; ``averaging`` is None without an ``[averaging]`` table;
    ``source`` is the file it was loaded from (not part of equality or ``to_dict``)."""

    info: SceneInfo
    geometry: Geometry | None
    species: tuple[Species, ...]
    particles: FreeParticles | None
    contact: Contact
    effects: Effects
    time: TimeCfg
    neighbors: Neighbors
    output: OutputCfg
    averaging: AveragingCfg | None
    source: str | None = field(default=None, compare=False)

    @property
    def n_free(self) -> int:
        """Total number of free (non-wall) particles."""
        if self.particles is not None:
            return len(self.particles)
        return sum(s.count for s in self.species)

    @property
    def min_free_diameter(self) -> float:
        """Smallest free-particle diameter (m); species with count 0 do not count."""
        if self.particles is not None:
            return float(self.particles.diameter.min())
        return min(s.diameter for s in self.species if s.count > 0)

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict in the TOML layout, every default filled in."""
        d: dict[str, Any] = {"scene": dataclasses.asdict(self.info)}
        if self.geometry is not None:
            d["geometry"] = {k: "auto" if v is None else v
                             for k, v in dataclasses.asdict(self.geometry).items()}
            d["species"] = [dataclasses.asdict(s) for s in self.species]
        if self.particles is not None:
            cols = [getattr(self.particles, k).tolist() for k in _PCOLS]
            d["particles"] = [dict(zip(_PCOLS, row)) for row in zip(*cols)]
        d["contact"] = dataclasses.asdict(self.contact)
        d["effects"] = dataclasses.asdict(self.effects)
        t = dataclasses.asdict(self.time)
        d["time"] = {**t, "dt": "auto" if t["dt"] is None else t["dt"]}
        d["neighbors"] = {"skin": "auto" if self.neighbors.skin is None else self.neighbors.skin}
        d["output"] = dataclasses.asdict(self.output)
        if self.averaging is not None:
            a = dataclasses.asdict(self.averaging)
            d["averaging"] = {**a, "reference_diameter": "auto" if a["reference_diameter"] is None
                              else a["reference_diameter"]}
        return d

    def fingerprint(self) -> str:
        """sha256 hex of the physics: to_dict() without scene.name, time.end, [output] and
        [averaging], which may legitimately change on a restart, and without keys added since
        the first release while they hold their default (time.integrator, the per-ring wall
        layout keys of [geometry])."""
        d = self.to_dict()
        d["scene"].pop("name")
        d["time"].pop("end")
        if d["time"]["integrator"] == "verlet":  # keys added later hash only when not default,
            d["time"].pop("integrator")          # so older checkpoints stay restartable
        for key, default in _LATER_GEOMETRY.items():
            if "geometry" in d and d["geometry"][key] == default:
                d["geometry"].pop(key)
        d.pop("output")
        d.pop("averaging", None)
        text = json.dumps(d, sort_keys=True, separators=(",", ":"), allow_nan=False)
        return hashlib.sha256(text.encode()).hexdigest()


_LATER_GEOMETRY = {f"{ring}_{key}": default for ring in ("inner", "outer") for key, default in
                   (("wall_count", "auto"), ("wall_diameter", "auto"), ("flat_surface", True))}
"""[geometry] keys added after the first release, with their defaults (see fingerprint)."""

# ---------------------------------------------------------------- schema and value checks

_REQ = object()  # marks a required key
_F, _I, _B, _S, _A, _IA = "float", "int", "bool", "str", "auto", "int-auto"


def _schema(cls: type, spec: dict[str, tuple[str, str, str]],
            defaults: dict[str, Any] | None = None) -> dict[str, tuple[str, Any, str, str]]:
    """key -> (kind, default, unit, rule); defaults come from the dataclass (single source)."""
    dflt = {f.name: _REQ if f.default is MISSING else f.default for f in dataclasses.fields(cls)}
    dflt.update(defaults or {})
    return {k: (kind, dflt[k], unit, rule) for k, (kind, unit, rule) in spec.items()}


_TABLES: dict[str, dict[str, tuple[str, Any, str, str]]] = {
    "scene": _schema(SceneInfo, {"name": (_S, "", ""), "kind": (_S, "", "couette|free"),
                                 "seed": (_I, "", ">=0")}, {"name": None}),
    "geometry": _schema(Geometry, {
        "inner_radius": (_F, "m", ">0"), "outer_radius": (_F, "m", ""),
        "outer_start_radius": (_F, "m", ""), "compression_time": (_F, "s", ">=0"),
        "omega_inner": (_F, "rad/s", ""), "wall_particle_diameter": (_F, "m", ">0"),
        "wall_particle_spacing": (_F, "m", ">0"),
        **{f"{ring}_{key}": spec for ring in ("inner", "outer") for key, spec in (
            ("wall_count", (_IA, "", ">=0")), ("wall_diameter", (_A, "m", ">0")),
            ("flat_surface", (_B, "", "")))}}),
    "species": _schema(Species, {"name": (_S, "", ""), "diameter": (_F, "m", ">0"),
                                 "mass": (_F, "kg", ">0"), "count": (_I, "", ">=0")}),
    "contact": _schema(Contact, {
        "k_n": (_F, "N/m", ">0"), "gamma_n": (_F, "kg/s", ">=0"), "k_t": (_F, "N/m", ">=0"),
        "mu": (_F, "", ">=0"), "mu_bottom": (_F, "", ">=0"), "gravity": (_F, "m/s^2", ">0"),
        "height": (_F, "m", ">0")}),
    "effects": _schema(Effects, {f.name: (_B, "", "") for f in dataclasses.fields(Effects)}),
    "time": _schema(TimeCfg, {"dt": (_A, "s", ">0"), "dt_per_contact": (_F, "", ">=5"),
                              "end": (_F, "s", ">0"),
                              "integrator": (_S, "", "verlet|verlet-halfstep")}),
    "neighbors": _schema(Neighbors, {"skin": (_A, "m", ">0")}),
    "output": _schema(OutputCfg, {"snapshot_interval": (_F, "s", ">0"),
                                  "checkpoint_interval": (_F, "s", ">0"),
                                  "contacts": (_B, "", "")}),
    "averaging": _schema(AveragingCfg, {
        "start": (_F, "s", ">=0"), "end": (_F, "s", ""), "sample_interval": (_F, "s", ">0"),
        "ring_width": (_F, "m", ">0"), "weighting": (_S, "", "slice|exact|centre|gaussian"),
        "reference_diameter": (_A, "m", ">0"), "displacement": (_S, "", "eta|spring")}),
}
_TOP_KEYS = ("scene", "geometry", "species", "particles", "particles_file", "contact", "effects",
             "time", "neighbors", "output", "averaging")
_PDEFAULT = {"vx": 0.0, "vy": 0.0, "omega": 0.0}


def _show(v: Any) -> str:
    """A value as the message shows it (TOML spelling for booleans)."""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        return repr(float(v))
    return repr(v)


def _is_num(v: Any) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def _value(label: str, key: str, v: Any, kind: str, unit: str) -> Any:
    """Type-check one value; ints become floats where floats are expected, "auto" -> None."""
    u = f" ({unit})" if unit else ""
    head = f"{label} {key} = {_show(v)}:"
    if kind == _B:
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
        raise SceneError(f"{head} expected a boolean (true or false)")
    if kind == _S:
        if isinstance(v, str):
            return v
        raise SceneError(f"{head} expected a string")
    if kind == _I:
        if isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_)):
            return int(v)
        raise SceneError(f"{head} expected an integer{u}")
    if kind in (_A, _IA) and isinstance(v, str) and v == "auto":
        return None
    if kind == _IA:
        if isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_)):
            return int(v)
        raise SceneError(f'{head} expected an integer or "auto"{u}')
    if not _is_num(v):
        raise SceneError(f"{head} expected a number{u}" + (' or "auto"' if kind == _A else ""))
    if not math.isfinite(float(v)):
        raise SceneError(f"{head} must be finite{u}")
    return float(v)


def _rule_ok(v: Any, rule: str) -> tuple[bool, str]:
    if "|" in rule:
        opts = rule.split("|")
        return v in opts, "must be one of " + ", ".join(repr(o) for o in opts)
    op, bound = (">=", rule[2:]) if rule.startswith(">=") else (">", rule[1:])
    return (v >= float(bound) if op == ">=" else v > float(bound)), f"must be {op} {bound}"


def _fail(label: str, key: str, v: Any, why: str, unit: str = "") -> SceneError:
    return SceneError(f"{label} {key} = {_show(v)}: {why}" + (f" ({unit})" if unit else ""))


def _parse(raw: Any, table: str, label: str) -> dict[str, Any]:
    """Check one table against its schema; returns every key with defaults filled in."""
    if not isinstance(raw, dict):
        raise SceneError(f"{label}: expected a table, got {_show(raw)}")
    schema = _TABLES[table]
    for key in raw:
        if key not in schema:
            raise SceneError(f"{label} unknown key {key!r}; allowed: {', '.join(schema)}")
    out: dict[str, Any] = {}
    for key, (kind, default, unit, rule) in schema.items():
        if key not in raw:
            if default is _REQ:
                raise SceneError(f"{label} {key}: missing (required)")
            out[key] = default
            continue
        v = out[key] = _value(label, key, raw[key], kind, unit)
        if rule and v is not None:
            ok, why = _rule_ok(v, rule)
            if not ok:
                raise _fail(label, key, raw[key], why, unit)
    return out


def _table_list(raw: Any, name: str) -> list[Any]:
    if not isinstance(raw, list) or not raw:
        raise SceneError(f"[[{name}]]: expected a non-empty array of tables")
    return raw


# ---------------------------------------------------------------- free particles

def _particles_from_tables(rows: list[Any]) -> dict[str, np.ndarray]:
    """Columns from ``[[particles]]`` tables; vectorised type checks keep 1e5 rows fast."""
    for i, r in enumerate(rows):
        if not isinstance(r, dict):
            raise SceneError(f"[[particles]] #{i}: expected a table, got {_show(r)}")
        extra = r.keys() - _PUNITS.keys()
        if extra:
            raise SceneError(f"[[particles]] #{i} unknown key {min(extra)!r}; "
                             f"allowed: {', '.join(_PCOLS)}")
    cols = {}
    for k in _PCOLS:
        dflt = _PDEFAULT.get(k, _REQ)
        vals = [r.get(k, dflt) for r in rows]
        if {type(v) for v in vals} <= {float, int, np.float64}:
            cols[k] = np.array(vals, dtype=np.float64)
            continue
        for i, v in enumerate(vals):  # slow path only to name the first bad row
            if v is _REQ:
                raise SceneError(f"[[particles]] #{i} {k}: missing (required)")
            _value(f"[[particles]] #{i}", k, v, _F, _PUNITS[k])
        cols[k] = np.array(vals, dtype=np.float64)
    return cols


def _particles_from_file(name: Any, base_dir: Path) -> dict[str, np.ndarray]:
    if not isinstance(name, str):
        raise SceneError(f"particles_file = {_show(name)}: expected a file name (.csv or .h5)")
    path = base_dir / name
    label = f"particles_file = {name!r}"
    if not path.is_file():
        raise SceneError(f"{label}: no such file {str(path)!r}")
    cols: dict[str, np.ndarray] = {}
    if path.suffix.lower() == ".csv":
        lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
        if len(lines) < 2:
            raise SceneError(f"{label}: expected a header row and at least one particle row")
        header = [h.strip() for h in lines[0].split(",")]
        try:
            data = np.loadtxt(lines[1:], delimiter=",", dtype=np.float64, ndmin=2)
        except ValueError as e:
            raise SceneError(f"{label}: unreadable CSV data: {e}") from None
        if data.shape[1] != len(header):
            raise SceneError(f"{label}: {data.shape[1]} columns but {len(header)} header names")
        cols = {h: data[:, j] for j, h in enumerate(header)}
    elif path.suffix.lower() in (".h5", ".hdf5"):
        import h5py  # only free scenes with HDF5 input pay for the import

        with h5py.File(path, "r") as f:
            for k, ds in f.items():
                if not isinstance(ds, h5py.Dataset) or ds.ndim != 1:
                    raise SceneError(f"{label}: {k!r} must be a 1-D dataset at the file root")
                cols[k] = np.asarray(ds[()], dtype=np.float64)
    else:
        raise SceneError(f"{label}: expected a .csv or .h5 file")
    for k in cols:
        if k not in _PUNITS:
            raise SceneError(f"{label}: unknown column {k!r}; allowed: {', '.join(_PCOLS)}")
    lengths = {len(c) for c in cols.values()}
    if len(lengths) > 1:
        raise SceneError(f"{label}: columns have different lengths {sorted(lengths)}")
    n = lengths.pop() if lengths else 0
    for k in _PCOLS:
        if k not in cols:
            if k not in _PDEFAULT:
                raise SceneError(f"{label}: required column {k!r} missing")
            cols[k] = np.full(n, _PDEFAULT[k])
    return cols


def _check_particles(cols: dict[str, np.ndarray], where: str) -> FreeParticles:
    """Finite values, positive diameter and mass, N >= 1, no coincident or deep overlaps."""
    n = len(cols["x"])
    if n == 0:
        raise SceneError(f"{where}: a free scene needs at least one particle")
    for k in _PCOLS:
        bad = ~np.isfinite(cols[k])
        if k in ("diameter", "mass"):
            bad |= ~(cols[k] > 0)
        if bad.any():
            i = int(np.argmax(bad))
            why = "must be > 0" if k in ("diameter", "mass") else "must be finite"
            raise _fail(f"{where} #{i}", k, cols[k][i], why, _PUNITS[k])
    x, y, d = cols["x"], cols["y"], cols["diameter"]
    pair = _worst_pair(x, y, d)
    if pair is not None:
        i, j = pair
        if x[i] == x[j] and y[i] == y[j]:
            raise SceneError(f"{where} #{i} and #{j}: identical positions ({x[i]!r}, {y[i]!r})")
        ov = 0.5 * (d[i] + d[j]) - math.hypot(x[i] - x[j], y[i] - y[j])
        raise SceneError(f"{where} #{i} and #{j} overlap by {ov:.3g} m = "
                         f"{100 * ov / min(d[i], d[j]):.3g}% of the smaller diameter "
                         "(at most 1% allowed)")
    return FreeParticles(**{k: cols[k] for k in _PCOLS})


def _worst_pair(x: np.ndarray, y: np.ndarray, d: np.ndarray) -> tuple[int, int] | None:
    """An (i, j), i < j, overlapping by > 1% of the smaller diameter, or None. Cell grid of side
    max(d), so only the 3x3 neighbourhood can overlap: O(N log N) while sizes are comparable."""
    n = x.size
    if n < 2:
        return None
    h = float(d.max())
    cx = np.floor((x - x.min()) / h).astype(np.int64)
    cy = np.floor((y - y.min()) / h).astype(np.int64) + 1  # +1: offset dcy = -1 stays >= 0
    ny = int(cy.max()) + 2
    if cx.max() >= 2**30 or ny >= 2**30:
        raise SceneError("[[particles]]: positions spread over more than 1e9 diameters")
    key = cx * ny + cy
    order = np.argsort(key, kind="stable")
    ks = key[order]
    rank = np.empty(n, np.int64)
    rank[order] = np.arange(n)
    for dcx, dcy in ((0, 0), (1, -1), (1, 0), (1, 1), (0, 1)):  # half stencil: each pair once
        nk = key + dcx * ny + dcy
        start = rank + 1 if dcx == dcy == 0 else np.searchsorted(ks, nk, "left")
        stop = np.searchsorted(ks, nk, "right")
        m = 0
        while True:
            pos = start + m
            live = np.nonzero(pos < stop)[0]
            if live.size == 0:
                break
            j = order[pos[live]]
            dist = np.hypot(x[live] - x[j], y[live] - y[j])
            ov = 0.5 * (d[live] + d[j]) - dist
            hit = (ov > 0.01 * np.minimum(d[live], d[j])) | (dist == 0)
            if hit.any():  # stop at the first hits: a heap of coincident disks stays cheap
                return min((min(a, b), max(a, b))
                           for a, b in zip(live[hit].tolist(), j[hit].tolist()))
            m += 1
    return None


# ---------------------------------------------------------------- scene assembly

def scene_from_dict(d: dict[str, Any], base_dir: str | Path = ".",
                    source: str | None = None) -> Scene:
    """Validate a dict in the TOML layout (as tomllib returns it) and build a Scene.
    ``base_dir`` resolves a relative ``particles_file``."""
    if not isinstance(d, dict):
        raise SceneError(f"scene: expected a table, got {_show(d)}")
    for key in d:
        if key not in _TOP_KEYS:
            raise SceneError(f"unknown top-level table or key {key!r}; allowed: "
                             f"{', '.join(_TOP_KEYS)}")
    if "scene" not in d:
        raise SceneError('[scene] table missing (required, with kind = "couette" or "free")')
    info = _parse(d["scene"], "scene", "[scene]")
    if info["name"] is None:
        info["name"] = Path(source).stem if source else "scene"
    kind = info["kind"]
    opt = {t: _parse(d.get(t, {}), t, f"[{t}]")
           for t in ("contact", "effects", "time", "neighbors", "output")}
    c, e = opt["contact"], opt["effects"]
    if e["tangential_friction"] and c["mu"] > 0 and c["k_t"] <= 0:
        raise _fail("[contact]", "k_t", c["k_t"], "must be > 0 when [effects] "
                    "tangential_friction is on and mu > 0", "N/m")
    averaging = None
    if "averaging" in d:
        a = _parse(d["averaging"], "averaging", "[averaging]")
        if not a["end"] > a["start"]:
            raise _fail("[averaging]", "end", a["end"], f"must be > start = {a['start']!r}", "s")
        averaging = AveragingCfg(**a)
    geometry, species, particles = None, (), None
    if kind == "couette":
        if "particles" in d or "particles_file" in d:
            which = "[[particles]]" if "particles" in d else "particles_file"
            raise SceneError(f"{which}: not allowed in a couette scene (particles are placed "
                             "randomly from [[species]])")
        if "species" not in d:
            raise SceneError("[[species]] missing: a couette scene needs at least one species")
        species = _species(_table_list(d["species"], "species"))
        geometry = _geometry(_parse(d.get("geometry", {}), "geometry", "[geometry]"), species)
    else:
        for t in ("species", "geometry"):
            if t in d:
                name = "[[species]]" if t == "species" else "[geometry]"
                raise SceneError(f"{name}: not allowed in a free scene (explicit particles, "
                                 "no rings)")
        if "particles" in d and "particles_file" in d:
            raise SceneError("[[particles]] and particles_file: give one or the other, not both")
        if "particles" in d:
            cols = _particles_from_tables(_table_list(d["particles"], "particles"))
            particles = _check_particles(cols, "[[particles]]")
        elif "particles_file" in d:
            cols = _particles_from_file(d["particles_file"], Path(base_dir))
            particles = _check_particles(cols, f"particles_file = {d['particles_file']!r} row")
        else:
            raise SceneError("[[particles]] missing: a free scene needs [[particles]] tables "
                             "or particles_file")
    return Scene(SceneInfo(**info), geometry, species, particles, Contact(**c), Effects(**e),
                 TimeCfg(**opt["time"]), Neighbors(**opt["neighbors"]),
                 OutputCfg(**opt["output"]), averaging, source)


def _species(rows: list[Any]) -> tuple[Species, ...]:
    out = tuple(Species(**_parse(r, "species", f"[[species]] #{i}")) for i, r in enumerate(rows))
    seen: set[str] = set()
    for i, s in enumerate(out):
        if s.name in seen:
            raise _fail(f"[[species]] #{i}", "name", s.name, "duplicate species name")
        seen.add(s.name)
    if sum(s.count for s in out) < 1:
        raise SceneError("[[species]] count: total count must be >= 1")
    return out


def _geometry(g: dict[str, Any], species: tuple[Species, ...]) -> Geometry:
    ri, ro = g["inner_radius"], g["outer_radius"]
    if not ro > ri:
        raise _fail("[geometry]", "outer_radius", ro,
                    f"must be > inner_radius = {ri!r} (R_o <= R_i)", "m")
    if g["outer_start_radius"] < ro:
        raise _fail("[geometry]", "outer_start_radius", g["outer_start_radius"],
                    f"outer start radius below the final radius outer_radius = {ro!r}", "m")
    big = max(species, key=lambda s: s.diameter)
    if not ro - ri > big.diameter:
        raise SceneError(f"[geometry] outer_radius - inner_radius = {ro - ri:.6g} m: the annulus "
                         f"gap must be larger than the largest diameter {big.diameter!r} m "
                         f"([[species]] {big.name!r})")
    geometry = Geometry(**g)
    from .walls import check_layout  # walls builds on scene types; imported here, not at the top

    small = min(s.diameter for s in species if s.count > 0)
    for ring in ("inner", "outer"):
        why = check_layout(geometry, ring, small)
        if why is not None:
            key, value, text = why
            raise _fail("[geometry]", key, value, text)
    return geometry


def load_scene(path: str | Path) -> Scene:
    """Read and validate a TOML scene file; errors are prefixed with the file path."""
    p = Path(path)
    if not p.is_file():
        raise SceneError(f"{p}: no such scene file")
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise SceneError(f"{p}: malformed TOML: {e}") from None
    try:
        return scene_from_dict(raw, base_dir=p.parent, source=str(p))
    except SceneError as e:
        raise SceneError(f"{p}: {e}") from None


# ---------------------------------------------------------------- TOML output

def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)  # shortest repr round-trips exactly; inf/nan are refused on input
    chars = []
    for ch in str(v):
        if ch in '"\\':
            chars.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            chars.append(f"\\u{ord(ch):04x}")
        else:
            chars.append(ch)
    return '"' + "".join(chars) + '"'


def scene_to_toml(scene: Scene) -> str:
    """The scene as TOML text with every key written; ``load_scene`` of it gives an equal
    ``to_dict()``."""
    out = [f"# pardem scene (SI units: m, kg, s, rad); kind = {scene.info.kind}"]
    for name, body in scene.to_dict().items():
        rows = body if isinstance(body, list) else [body]
        head = f"[[{name}]]" if isinstance(body, list) else f"[{name}]"
        for row in rows:
            out += ["", head] + [f"{k} = {_toml_value(v)}" for k, v in row.items()]
    return "\n".join(out) + "\n"


def write_scene(scene: Scene, path: str | Path) -> None:
    """Write ``scene_to_toml(scene)`` atomically (temporary file, then ``os.replace``)."""
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(scene_to_toml(scene), encoding="utf-8")
    os.replace(tmp, p)

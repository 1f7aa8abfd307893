"""The checks of a scene: every table's keys, kinds, units, defaults and allowed values, and the
assembly of a validated ``Scene`` from a dict in the TOML layout (``scene_from_dict``).

Stage: input. Defaults come from the dataclasses of ``scene.py`` (one source); each check
raises ``SceneError`` naming the ``[table] key``, its value and what is allowed.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import MISSING
from pathlib import Path
from typing import Any

from ..contact.keys import check_law, check_slots
from ..contact.pairs import BOUNDARIES
from .pair_table import check_pairs
from .particles import check_particles, particles_from_file, particles_from_tables
from ..boundaries.wall_file import wall_disks_of
from .scene import (AveragingCfg, Contact, Effects, Geometry, Neighbors, OutputCfg, Scene,
                    SceneError, SceneInfo, Species, TimeCfg)
from .species import check_species, disks_of, free_area
from .values import AUTO, BOOL, FLOAT, INT, INT_AUTO, OFF, REQ, STR, fail, rule_ok, show, value
from .warnings_table import WarningsCfg


KINDS = {"float": FLOAT, "int": INT, "bool": BOOL, "str": STR, "float | None": AUTO,
         "int | None": INT_AUTO, "float | bool": OFF}


def _schema(cls: type) -> dict[str, tuple[str, Any, str, str]]:
    """key -> (kind, default, unit, rule) of a table's dataclass (scene.key declares them)."""
    return {f.name: (KINDS[f.type], REQ if f.default is MISSING else f.default,
                     f.metadata["unit"], f.metadata["rule"]) for f in dataclasses.fields(cls)}


_TABLES = {name: _schema(cls) for name, cls in (
    ("scene", SceneInfo), ("geometry", Geometry), ("species", Species), ("contact", Contact),
    ("effects", Effects), ("time", TimeCfg), ("neighbors", Neighbors), ("output", OutputCfg),
    ("averaging", AveragingCfg), ("warnings", WarningsCfg))}
_TOP_KEYS = ("scene", "geometry", "species", "particles", "particles_file", "wall_disks",
             "wall_disks_file", "contact", "effects", "time", "neighbors", "output", "averaging",
             "warnings")


def _parse(raw: Any, table: str, label: str) -> dict[str, Any]:
    """Check one table against its schema; returns every key with defaults filled in."""
    if not isinstance(raw, dict):
        raise SceneError(f"{label}: expected a table, got {show(raw)}")
    schema = _TABLES[table]
    for key in raw:
        if key not in schema:
            raise SceneError(f"{label} unknown key {key!r}; allowed: {', '.join(schema)}")
    out: dict[str, Any] = {}
    for key, (kind, default, unit, rule) in schema.items():
        if key not in raw:
            if default is REQ:
                raise SceneError(f"{label} {key}: missing (required)")
            out[key] = default
            continue
        v = out[key] = value(label, key, raw[key], kind, unit)
        if rule and v is not None and v is not False:  # "auto" and "off" obey no rule
            ok, why = rule_ok(v, rule)
            if not ok:
                raise fail(label, key, raw[key], why, unit)
    return out


def _table_list(raw: Any, name: str) -> list[Any]:
    if not isinstance(raw, list) or not raw:
        raise SceneError(f"[[{name}]]: expected a non-empty array of tables")
    return raw


def scene_from_dict(d: dict[str, Any], base_dir: str | Path = ".",
                    source: str | None = None) -> Scene:
    """Validate a dict in the TOML layout (as tomllib returns it) and build a Scene.
    ``base_dir`` resolves a relative ``particles_file`` and ``wall_disks_file``."""
    if not isinstance(d, dict):
        raise SceneError(f"scene: expected a table, got {show(d)}")
    for key in d:
        if key not in _TOP_KEYS:
            raise SceneError(f"unknown top-level table or key {key!r}; allowed: "
                             f"{', '.join(_TOP_KEYS)}")
    if "scene" not in d:
        raise SceneError('[scene] table missing (required, with kind = "couette" or "free")')
    info = _parse(d["scene"], "scene", "[scene]")
    if info["name"] is None:
        info["name"] = Path(source).stem if source else "scene"
    why = name_problem(info["name"])
    if why:
        raise fail("[scene]", "name", info["name"], why)
    kind = info["kind"]
    raw = {t: d.get(t, {}) for t in ("contact", "effects", "time", "neighbors", "output",
                                  "warnings")}
    pair_rows = None
    if isinstance(raw["contact"], dict) and "pair" in raw["contact"]:
        raw["contact"] = dict(raw["contact"])
        pair_rows = raw["contact"].pop("pair")
    opt = {t: _parse(r, t, f"[{t}]") for t, r in raw.items()}
    c, e = opt["contact"], opt["effects"]
    check_slots(c, e)
    check_law(c, raw["contact"])
    averaging = None
    if "averaging" in d:
        a = _parse(d["averaging"], "averaging", "[averaging]")
        if not a["end"] > a["start"]:
            raise fail("[averaging]", "end", a["end"], f"must be > start = {a['start']!r}", "s")
        window = a["end"] - a["start"]
        if math.isfinite(window) and a["sample_interval"] > window:
            raise fail("[averaging]", "sample_interval", a["sample_interval"],
                       f"longer than the averaging window end - start = {window:g} s: "
                       "not one sample apart", "s")
        averaging = AveragingCfg(**a)
    geometry, species, particles = None, (), None
    if kind == "couette":
        if "particles" in d or "particles_file" in d:
            which = "[[particles]]" if "particles" in d else "particles_file"
            raise SceneError(f"{which}: not allowed in a couette scene (particles are placed "
                             "randomly from [[species]])")
        if "species" not in d:
            raise SceneError("[[species]] missing: a couette scene needs at least one species")
        species = _species(_table_list(d["species"], "species"), c["height"])
        g = _parse(d.get("geometry", {}), "geometry", "[geometry]")
        _check_counts(species, g["volume_fraction"] is not None)
        species, geometry = _counts(species, _geometry(g, species), info["seed"], c["height"])
        _fit(species, geometry, info["seed"], c["height"])
        gap = geometry.outer_radius - geometry.inner_radius
        if averaging is not None and averaging.ring_width is not None:
            why = ring_width_problem(averaging.ring_width, gap)
            if why:
                raise fail("[averaging]", "ring_width", averaging.ring_width, why, "m")
    else:
        for t in ("species", "geometry", "averaging"):
            if t in d:
                name = "[[species]]" if t == "species" else f"[{t}]"
                raise SceneError(f"{name}: not allowed in a free scene (explicit particles, "
                                 "no rings to average over)")
        if "particles" in d and "particles_file" in d:
            raise SceneError("[[particles]] and particles_file: give one or the other, not both")
        if "particles" in d:
            cols = particles_from_tables(_table_list(d["particles"], "particles"))
            particles = check_particles(cols, "[[particles]]")
        elif "particles_file" in d:
            cols = particles_from_file(d["particles_file"], Path(base_dir))
            particles = check_particles(cols, f"particles_file = {d['particles_file']!r} row")
        else:
            raise SceneError("[[particles]] missing: a free scene needs [[particles]] tables "
                             "or particles_file")
    pairs = ()
    if pair_rows is not None:
        partners = (tuple(s.name for s in species) + BOUNDARIES if kind == "couette" else
                    tuple(range(int(particles.species.max()) + 1)))
        pairs = check_pairs(pair_rows, c, raw["contact"], e, partners)
    return Scene(SceneInfo(**info), geometry, species, particles, Contact(**c), Effects(**e),
                 TimeCfg(**opt["time"]), Neighbors(**opt["neighbors"]),
                 OutputCfg(**opt["output"]), averaging, pairs, source,
                 wall_disks_of(d, kind, particles, Path(base_dir)), WarningsCfg(**opt["warnings"]))


def _species(rows: list[Any], height: float) -> tuple[Species, ...]:
    """The [[species]] tables, each with its mass (from its density and the disks' height
    ``height`` if given so)."""
    out = tuple(check_species(Species(**_parse(r, "species", f"[[species]] #{i}")), i, height)
                for i, r in enumerate(rows))
    seen: set[str] = set()
    for i, s in enumerate(out):
        if s.name in seen:
            raise fail(f"[[species]] #{i}", "name", s.name, "duplicate species name")
        seen.add(s.name)
    return out


def _check_counts(species: tuple[Species, ...], filling: bool) -> None:
    """A count per species, or with [geometry] volume_fraction (``filling``) a share."""
    for i, s in enumerate(species):
        if filling and s.count is not None:
            raise fail(f"[[species]] #{i}", "count", s.count, "not allowed with [geometry] "
                       "volume_fraction (give share, the species' part by number)")
        if filling and s.share is None:
            raise SceneError(f"[[species]] #{i} share: missing (required with [geometry] "
                             "volume_fraction)")
        if not filling and s.share is not None:
            raise fail(f"[[species]] #{i}", "share", s.share, "needs [geometry] "
                       "volume_fraction (without it, give count)")
        if not filling and s.count is None:
            raise SceneError(f"[[species]] #{i} count: missing (required, or [geometry] "
                             "volume_fraction with a share per species)")


def name_problem(name: str) -> str | None:
    """Why ``name`` cannot name a run (its default folder is runs/<name>), or None."""
    if not name.strip():
        return "empty; give a name (the default run folder is runs/<name>)"
    if name in (".", "..") or any(c in name for c in "/\\"):
        return "a name, not a path (no / or \\, not . or ..): the run folder is runs/<name>"
    if any(ord(c) < 0x20 or ord(c) == 0x7F for c in name):
        return "control characters are not allowed"
    return None


HEXAGONAL_PACKING = math.pi / (2.0 * math.sqrt(3.0))
MAX_RINGS = 100_000
"""The most rings an averaging may have (a ring holds a row of sums per sample)."""


def ring_width_problem(width: float, gap: float) -> str | None:
    """Why rings of ``width`` (m) cannot cover a gap of ``gap`` (m), or None."""
    if width > gap * (1 + 1e-9):  # one ring as wide as the gap is fine (0.09 - 0.05 < 0.04)
        return f"wider than the gap outer_radius - inner_radius = {gap:.6g} m"
    if gap / width > MAX_RINGS:
        return (f"{gap / width:.3g} rings across the gap of {gap:.6g} m; at most {MAX_RINGS} "
                f"(ring_width >= {gap / MAX_RINGS:.3g} m)")
    return None


def densest_packing(species: tuple[Species, ...]) -> tuple[float, str]:
    """The fraction no cell of these disks can be compressed beyond, and what it is: the
    hexagonal packing for one diameter; for several, only the cell's whole area (small disks
    can fill the holes between large ones)."""
    if len({s.diameter for s in species}) == 1 and not species[0].distributed:
        return HEXAGONAL_PACKING, "the densest packing of equal disks"
    return 1.0, "the whole cell"


def _counts(species: tuple[Species, ...], g: Geometry, seed: int,
            height: float) -> tuple[tuple[Species, ...], Geometry]:
    """Every species' count: given, or from [geometry] volume_fraction and the shares (the
    resolved scene keeps the counts and drops the fraction and shares; a distribution
    counts with its mean disk area)."""
    from ..boundaries.walls import wall_area_share

    area = math.pi * (g.outer_radius**2 - g.inner_radius**2)
    walls = wall_area_share(g)
    densest, what = densest_packing(species)
    if g.volume_fraction is not None:
        if g.volume_fraction > densest:
            raise fail("[geometry]", "volume_fraction", g.volume_fraction,
                       f"above {densest:.4f}, {what}")
        # shares are relative: divide by the largest first (1e308 + 1e308 overflows)
        top = max(s.share for s in species)
        total = sum(s.share / top for s in species)
        per_disk = sum(s.share / top / total * math.pi * s.diameter**2 / 4 if not s.distributed
                       else s.share / top / total * s.mean_area() for s in species)
        n = (g.volume_fraction * area - walls) / per_disk
        if n < 1:
            raise fail("[geometry]", "volume_fraction", g.volume_fraction,
                       f"the wall disks alone fill {walls / area:.4f} of the cell")
        species = tuple(dataclasses.replace(s, count=int(round(s.share / top / total * n)),
                                            share=None) for s in species)
        g = dataclasses.replace(g, volume_fraction=None)
    if sum(s.count for s in species) < 1:
        raise SceneError("[[species]] count: total count must be >= 1")
    # the free disks alone: wall disks may overlap, so their share bounds nothing here
    nu = free_area(species, seed, height) / area
    if nu > densest:
        raise SceneError(
            f"[[species]] count: {sum(s.count for s in species)} disks fill {nu:.4f} of the "
            f"cell between inner_radius and outer_radius, above {densest:.4f}, {what}; reduce "
            "the counts or enlarge outer_radius")
    return species, g


def _geometry(g: dict[str, Any], species: tuple[Species, ...]) -> Geometry:
    from ..boundaries.walls import check_sizes  # walls builds on scene types (as in _fit)

    ri, ro = g["inner_radius"], g["outer_radius"]
    if not ro > ri:
        raise fail("[geometry]", "outer_radius", ro,
                    f"must be > inner_radius = {ri!r} (R_o <= R_i)", "m")
    if g["outer_start_radius"] < ro:
        raise fail("[geometry]", "outer_start_radius", g["outer_start_radius"],
                    f"outer start radius below the final radius outer_radius = {ro!r}", "m")
    # the largest a disk can be before the counts give the drawn ones (_fit)
    _across(ro - ri, [(s.diameter_max if s.distributed else s.diameter, s, "largest diameter")
                      for s in species])
    geometry = Geometry(**g)
    why = check_sizes(geometry)  # before the wall disks' area or count is computed (_counts)
    if why is not None:
        key, value, text = why
        raise fail("[geometry]", key, value, text, "m")
    return geometry


def _across(gap: float, disks: list[tuple[float | None, Species, str]]) -> None:
    """The largest of ``disks`` (diameter m or None: not known, its species, what it is) fits
    across the annulus gap."""
    d, s, what = max((x for x in disks if x[0] is not None), key=lambda x: x[0],
                     default=(None, None, ""))
    if d is not None and not gap > d:
        raise SceneError(f"[geometry] outer_radius - inner_radius = {gap:.6g} m: the annulus "
                         f"gap must be larger than the {what} {d!r} m ([[species]] {s.name!r})")


def _fit(species: tuple[Species, ...], g: Geometry, seed: int, height: float) -> None:
    """The disks (a distribution's as drawn) fit the cell: the largest across the gap, the
    smallest held in by each ring's wall disks."""
    from ..boundaries.walls import check_layout  # walls builds on scene types; imported here, not at the top

    drawn = [(s, disks_of(s, i, seed, height)[0]) for i, s in enumerate(species)]
    drawn = [(s, d) for s, d in drawn if d.size]
    _across(g.outer_radius - g.inner_radius,
            [(float(d.max()), s, "largest drawn diameter") for s, d in drawn])
    small = min(float(d.min()) for _, d in drawn)
    for ring in ("inner", "outer"):
        why = check_layout(g, ring, small)
        if why is not None:
            key, value, text = why
            raise fail("[geometry]", key, value, text)

"""The checks of a scene: every table's keys, kinds, units, defaults and allowed values, and the
assembly of a validated ``Scene`` from a dict in the TOML layout (``scene_from_dict``).

Stage: input. Defaults come from the dataclasses of ``scene.py`` (one source); each check
raises ``SceneError`` naming the ``[table] key``, its value and what is allowed.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import MISSING
from pathlib import Path
from typing import Any

import numpy as np

from .contact.model import check_slots
from .particles_input import check_particles, particles_from_file, particles_from_tables
from .scene import (AveragingCfg, Contact, Effects, Geometry, Neighbors, OutputCfg, Scene,
                    SceneError, SceneInfo, Species, TimeCfg)
from .values import AUTO, BOOL, FLOAT, INT, INT_AUTO, REQ, STR, fail, rule_ok, show, value


KINDS = {"float": FLOAT, "int": INT, "bool": BOOL, "str": STR, "float | None": AUTO,
         "int | None": INT_AUTO}


def _schema(cls: type) -> dict[str, tuple[str, Any, str, str]]:
    """key -> (kind, default, unit, rule) of a table's dataclass (scene.key declares them)."""
    return {f.name: (KINDS[f.type], REQ if f.default is MISSING else f.default,
                     f.metadata["unit"], f.metadata["rule"]) for f in dataclasses.fields(cls)}


_TABLES = {name: _schema(cls) for name, cls in (
    ("scene", SceneInfo), ("geometry", Geometry), ("species", Species), ("contact", Contact),
    ("effects", Effects), ("time", TimeCfg), ("neighbors", Neighbors), ("output", OutputCfg),
    ("averaging", AveragingCfg))}
_TOP_KEYS = ("scene", "geometry", "species", "particles", "particles_file", "contact", "effects",
             "time", "neighbors", "output", "averaging")


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
        if rule and v is not None:
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
    ``base_dir`` resolves a relative ``particles_file``."""
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
    kind = info["kind"]
    opt = {t: _parse(d.get(t, {}), t, f"[{t}]")
           for t in ("contact", "effects", "time", "neighbors", "output")}
    c, e = opt["contact"], opt["effects"]
    check_slots(c, e)
    averaging = None
    if "averaging" in d:
        a = _parse(d["averaging"], "averaging", "[averaging]")
        if not a["end"] > a["start"]:
            raise fail("[averaging]", "end", a["end"], f"must be > start = {a['start']!r}", "s")
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
        gap = geometry.outer_radius - geometry.inner_radius
        if averaging is not None and (averaging.ring_width or 0.0) > gap:
            raise fail("[averaging]", "ring_width", averaging.ring_width,
                       f"wider than the gap outer_radius - inner_radius = {gap:.6g} m", "m")
    else:
        for t in ("species", "geometry"):
            if t in d:
                name = "[[species]]" if t == "species" else "[geometry]"
                raise SceneError(f"{name}: not allowed in a free scene (explicit particles, "
                                 "no rings)")
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
    return Scene(SceneInfo(**info), geometry, species, particles, Contact(**c), Effects(**e),
                 TimeCfg(**opt["time"]), Neighbors(**opt["neighbors"]),
                 OutputCfg(**opt["output"]), averaging, source)


def _species(rows: list[Any]) -> tuple[Species, ...]:
    out = tuple(Species(**_parse(r, "species", f"[[species]] #{i}")) for i, r in enumerate(rows))
    seen: set[str] = set()
    for i, s in enumerate(out):
        if s.name in seen:
            raise fail(f"[[species]] #{i}", "name", s.name, "duplicate species name")
        seen.add(s.name)
    if sum(s.count for s in out) < 1:
        raise SceneError("[[species]] count: total count must be >= 1")
    return out


def _geometry(g: dict[str, Any], species: tuple[Species, ...]) -> Geometry:
    ri, ro = g["inner_radius"], g["outer_radius"]
    if not ro > ri:
        raise fail("[geometry]", "outer_radius", ro,
                    f"must be > inner_radius = {ri!r} (R_o <= R_i)", "m")
    if g["outer_start_radius"] < ro:
        raise fail("[geometry]", "outer_start_radius", g["outer_start_radius"],
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
            raise fail("[geometry]", key, value, text)
    return geometry


"""Scene loading, validation, TOML round trip, fingerprint and time-step resolution."""

from __future__ import annotations

import copy
import dataclasses
import math
import re
import tomllib
from fractions import Fraction
from pathlib import Path

import h5py
import numpy as np
import pytest

from pardem.input.scene import FreeParticles, Scene, SceneError
from pardem.input.schema import scene_from_dict
from pardem.input.scene_file import load_scene, scene_to_toml, write_scene
from pardem.contact.damped_spring import restitution
from pardem.check import describe
from pardem.core.scales import contact_time, smallest_contact_time, smallest_reduced_mass
from pardem.core.timestep import off_step, resolve_dt, resolve_step, time_quantum

ROOT = Path(__file__).resolve().parents[1]
RUN_SCRIPTS = sorted((ROOT / "run_scripts" / "scenes").glob("*.toml"))
D_S, M_S, D_L, M_L = 7.42e-3, 0.275e-3, 8.99e-3, 0.490e-3


def couette_dict() -> dict:
    return {"scene": {"name": "c", "kind": "couette", "seed": 2},
            "geometry": {},
            "species": [{"name": "small", "diameter": D_S, "mass": M_S, "count": 2545},
                        {"name": "large", "diameter": D_L, "mass": M_L, "count": 394}],
            "contact": {}, "effects": {}, "time": {"dt": "auto", "end": 1.0}}


def free_dict() -> dict:
    return {"scene": {"name": "f", "kind": "free"},
            "particles": [{"x": -5e-3, "y": 0.0, "vx": 0.05, "diameter": D_S, "mass": M_S},
                          {"x": 5e-3, "y": 0.0, "vx": -0.05, "diameter": D_S, "mass": M_S}],
            "time": {"end": 0.05}}


def mutate(base: dict, path: str, value) -> dict:
    """Set d[a][b]... (list indices as ints); value DELETE removes the key."""
    d = copy.deepcopy(base)
    *head, last = [int(p) if p.isdigit() else p for p in path.split(".")]
    target = d
    for p in head:
        target = target[p]
    if value is DELETE:
        del target[last]
    else:
        target[last] = value
    return d


class _Delete:
    def __repr__(self):  # a stable test id (pytest-xdist workers must collect the same ids)
        return "DELETE"


DELETE = _Delete()

BAD_COUETTE = [
    ("contact.k_n", -1.0, r"[contact] k_n = -1.0: must be > 0 (N/m)"),
    ("contact.k_n", 0, r"[contact] k_n = 0: must be > 0"),
    ("contact.height", 0.0, r"[contact] height"),
    ("contact.gravity", -9.81, r"[contact] gravity"),
    ("contact.gamma_n", -0.1, r"[contact] gamma_n = -0.1: must be >= 0"),
    ("contact.k_t", -1.0, r"[contact] k_t"),
    ("contact.mu", -0.1, r"[contact] mu = -0.1"),
    ("contact.mu_bottom", -1e-5, r"[contact] mu_bottom"),
    ("contact.k_n", True, r"[contact] k_n = true: expected a number"),
    ("contact.k_n", "352", r"[contact] k_n = '352': expected a number (N/m)"),
    ("contact.k_n", float("nan"), r"[contact] k_n = nan: must be finite"),
    ("contact.k_nn", 1.0, r"[contact] unknown key 'k_nn'; allowed: normal, k_n, gamma_n"),
    ("time.end", "abc", r"[time] end = 'abc': expected a number (s)"),
    ("time.end", 0.0, r"[time] end"),
    ("time.dt", -1e-5, r"[time] dt = -1e-05: must be > 0"),
    ("time.dt", "fast", "[time] dt = 'fast': expected a number (s) or \"auto\""),
    ("time.dt_per_contact", 4, r"[time] dt_per_contact = 4: must be >= 5"),
    ("effects.rotation", 1, r"[effects] rotation = 1: expected a boolean"),
    ("effects.rotation", "true", r"[effects] rotation"),
    ("effects.spin", True, r"[effects] unknown key 'spin'"),
    ("geometry.outer_radiuss", 0.3,
     r"[geometry] unknown key 'outer_radiuss'; allowed: inner_radius,"),
    ("geometry.inner_radius", 0.0, r"[geometry] inner_radius"),
    ("geometry.outer_radius", 0.1, r"[geometry] outer_radius = 0.1: .*R_o <= R_i"),
    ("geometry.outer_start_radius", 0.2,
     r"[geometry] outer_start_radius = 0.2: outer start radius below"),
    ("geometry.compression_time", -1.0, r"[geometry] compression_time"),
    ("geometry.wall_particle_diameter", 0.0, r"[geometry] wall_particle_diameter"),
    ("geometry.wall_particle_spacing", 0.0,
     r"[geometry] wall_particle_spacing = 0.0: must be > 0 (m)"),
    ("geometry.inner_wall_count", -1, r"[geometry] inner_wall_count = -1: must be >= 0"),
    ("geometry.outer_wall_count", 2.5,
     r'[geometry] outer_wall_count = 2.5: expected an integer or "auto"'),
    ("geometry.outer_wall_count", "many",
     '[geometry] outer_wall_count = \'many\': expected an integer or "auto"'),
    ("geometry.inner_wall_diameter", 0.0, r"[geometry] inner_wall_diameter = 0.0: must be > 0"),
    ("geometry.inner_flat_surface", "no", r"[geometry] inner_flat_surface = 'no': expected a"),
    ("geometry", 3, r"[geometry]: expected a table"),
    ("species.0.diameter", -7e-3, r"[[species]] #0 diameter = -0.007: must be > 0 (m)"),
    ("species.1.mass", 0.0, r"[[species]] #1 mass"),
    ("species.0.count", -1, r"[[species]] #0 count = -1: must be >= 0"),
    ("species.0.count", 2.5, r"[[species]] #0 count = 2.5: expected an integer"),
    ("species.0.count", 2545.0, r"[[species]] #0 count = 2545.0: expected an integer"),
    ("species.1.name", "small", r"[[species]] #1 name = 'small': duplicate species name"),
    ("species.0.colour", "red", r"[[species]] #0 unknown key 'colour'"),
    ("species.0.mass", DELETE, r"[[species]] #0 mass: missing"),
    ("species", [], r"[[species]]"),
    ("species", DELETE, r"[[species]] missing"),
    ("scene.kind", "box", r"[scene] kind = 'box': must be one of 'couette', 'free'"),
    ("scene.kind", DELETE, r"[scene] kind: missing"),
    ("scene", DELETE, r"[scene] table missing"),
    ("scene.seed", -1, r"[scene] seed = -1"),
    ("scene.seed", 1.5, r"[scene] seed = 1.5: expected an integer"),
    ("output.snapshot_interval", 0.0, r"[output] snapshot_interval"),
    ("output.checkpoint_interval", -1.0, r"[output] checkpoint_interval"),
    ("output.contacts", "yes", r"[output] contacts"),
    ("neighbors.skin", 0.0, r"[neighbors] skin = 0.0: must be > 0"),
    ("time.integrator", "gear", r"[time] integrator = 'gear': must be one of 'verlet', "
                                r"'verlet-halfstep'"),
    ("neighbors.skin", "big", r"[neighbors] skin"),
    ("averaging.start", -1.0, r"[averaging] start"),
    ("averaging.sample_interval", 0.0, r"[averaging] sample_interval"),
    ("averaging.ring_width", 0.0, r"[averaging] ring_width"),
    ("averaging.weighting", "area", r"[averaging] weighting = 'area': must be one of 'slice'"),
    ("averaging.reference_diameter", -8e-3, r"[averaging] reference_diameter = -0.008"),
    ("averaging.reference_diameter", "big", r"[averaging] reference_diameter = 'big'"),
    ("averaging.displacement", "xi",
     r"[averaging] displacement = 'xi': must be one of 'spring', 'eta'"),
    ("particles", [{"x": 0.0, "y": 0.0, "diameter": D_S, "mass": M_S}],
     r"[[particles]]: not allowed in a couette scene"),
    ("particles_file", "init.csv", r"particles_file: not allowed in a couette scene"),
    ("bogus", {}, r"unknown top-level table or key 'bogus'"),
    # the name is the default run folder runs/<name>: a name, never a path
    ("scene.name", "../../etc/x", r"[scene] name = '../../etc/x': a name, not a path"),
    ("scene.name", "/tmp/x", r"[scene] name = '/tmp/x': a name, not a path"),
    ("scene.name", "..", r"[scene] name = '..': a name, not a path"),
    ("scene.name", "a\\b", r"[scene] name = 'a\\b': a name, not a path"),
    ("scene.name", " ", r"[scene] name = ' ': empty"),
    ("scene.name", "a\x00b", r"[scene] name = 'a\x00b': control characters are not allowed"),
    ("time.dt_per_contact", 1e300, r"[time] dt_per_contact = 1e+300: must be <= 1e6"),
    # a ring per 1.5 um at most: 0.149 m / 1e5
    ("averaging.ring_width", 1e-12,
     r"[averaging] ring_width = 1e-12: 1.49e+11 rings across the gap of 0.149 m; at most 100000"),
]


@pytest.mark.parametrize("path,value,message", BAD_COUETTE,
                         ids=[f"{p}={v!r}"[:40] for p, v, _ in BAD_COUETTE])
def test_bad_couette_value(path, value, message):
    d = couette_dict()
    d["neighbors"] = {}
    d["output"] = {}
    d["averaging"] = {}
    with pytest.raises(SceneError, match=re.escape(message).replace(r"\.\*", ".*")):
        scene_from_dict(mutate(d, path, value))


@pytest.mark.parametrize("changes,message", [
    ({"contact.k_t": 0.0}, "[contact] k_t = 0.0: must be > 0 when [effects] tangential_friction"),
    ({"averaging": {"start": 10.0, "end": 5.0}}, "[averaging] end = 5.0: must be > start = 10.0"),
    ({"averaging": {"ring_width": 0.2}},
     "[averaging] ring_width = 0.2: wider than the gap outer_radius - inner_radius = 0.149 m"),
    ({"geometry.outer_radius": 0.108}, "[geometry] outer_radius - inner_radius"),
    ({"species.0.count": 0, "species.1.count": 0}, "total count must be >= 1"),
    # area: pi (0.2525^2 - 0.1035^2) = 0.166643 m^2; a disk of 7.42 mm 4.32412e-5 m^2, of
    # 8.99 mm 6.34761e-5 m^2; the wall disks are left out (they may overlap)
    ({"species.0.count": 3545},  # + 394 of 8.99 mm: (0.153290 + 0.025010) / 0.166643
     "[[species]] count: 3939 disks fill 1.0700 of the cell"),
    ({"species.0.count": 3200, "species.1.diameter": D_S},  # one size: hexagonal at most
     "fill 0.9326 of the cell between inner_radius and outer_radius, above 0.9069, the "
     "densest packing of equal disks"),
    ({"geometry.inner_wall_count": 0, "geometry.inner_flat_surface": False},
     "[geometry] inner_flat_surface = false: a ring with inner_wall_count = 0 (smooth) needs "
     "its flat surface"),
    ({"geometry.outer_wall_count": 60, "geometry.outer_flat_surface": False},
     "[geometry] outer_flat_surface = false: without the flat surface the 60 wall disks leave "
     "gaps of"),
    ({"geometry.inner_wall_diameter": 0.2},
     "[geometry] inner_wall_diameter = 0.2: the inner ring's wall disks must be smaller than "
     "the annulus gap outer_radius - inner_radius = 0.149"),
    ({"geometry.inner_wall_count": 10**7},
     "[geometry] inner_wall_count = 10000000: more than 1000000 disks on a ring"),
    # 2 pi 0.1035 m / 2.5 mm = 260 diameters along the inner ring: 26,000 disks at most
    ({"geometry.inner_wall_count": 30_000},
     "[geometry] inner_wall_count = 30000: more than 100 disks per wall-disk diameter"),
])
def test_bad_couette_combination(changes, message):
    d = couette_dict()
    for path, value in changes.items():
        d = mutate(d, path, value)
    with pytest.raises(SceneError, match=re.escape(message)):
        scene_from_dict(d)


def test_k_t_zero_allowed_without_friction():
    d = mutate(mutate(couette_dict(), "contact.k_t", 0.0), "effects.tangential_friction", False)
    assert scene_from_dict(d).contact.k_t == 0.0
    d = mutate(mutate(couette_dict(), "contact.k_t", 0.0), "contact.mu", 0.0)
    assert scene_from_dict(d).contact.mu == 0.0


BAD_FREE = [
    ("species", [{"name": "s", "diameter": D_S, "mass": M_S, "count": 1}],
     "[[species]]: not allowed in a free scene"),
    ("geometry", {}, "[geometry]: not allowed in a free scene"),
    ("averaging", {}, "[averaging]: not allowed in a free scene (explicit particles, no rings"),
    ("particles", DELETE, "[[particles]] missing"),
    ("particles_file", "init.csv", "[[particles]] and particles_file: give one or the other"),
    ("particles.1.diameter", -1.0, "[[particles]] #1 diameter = -1.0: must be > 0 (m)"),
    ("particles.0.mass", 0, "[[particles]] #0 mass = 0.0: must be > 0 (kg)"),
    ("particles.0.mass", DELETE, "[[particles]] #0 mass: missing"),
    ("particles.1.vx", "fast", "[[particles]] #1 vx = 'fast': expected a number (m/s)"),
    ("particles.1.vx", False, "[[particles]] #1 vx = false: expected a number"),
    ("particles.0.z", 0.0, "[[particles]] #0 unknown key 'z'"),
    ("particles.1.x", -5e-3, "[[particles]] #0 and #1: identical positions"),
    ("particles.1.x", 0.0, "[[particles]] #0 and #1 overlap by"),
    ("particles", [], "[[particles]]: expected a non-empty array of tables"),
    # cell indices would overflow int64 before any size check on them
    ("particles.1.x", 1e200, "[[particles]]: positions spread over more than 1e9 diameters"),
    ("particles.0.y", -1e300, "[[particles]]: positions spread over more than 1e9 diameters"),
]


@pytest.mark.parametrize("path,value,message", BAD_FREE,
                         ids=[f"{p}={v!r}"[:40] for p, v, _ in BAD_FREE])
def test_bad_free_value(path, value, message):
    with pytest.raises(SceneError, match=re.escape(message)):
        scene_from_dict(mutate(free_dict(), path, value))


def test_small_overlap_is_accepted_large_refused():
    d = free_dict()
    d["particles"][0]["x"] = -D_S / 2 + 0.004 * D_S  # 0.8% overlap
    d["particles"][1]["x"] = D_S / 2 - 0.004 * D_S
    assert scene_from_dict(d).n_free == 2
    d["particles"][1]["x"] = D_S / 2 - 0.007 * D_S  # 1.1% overlap
    with pytest.raises(SceneError, match=r"#0 and #1 overlap by .*% of the smaller diameter"):
        scene_from_dict(d)


def test_overlap_search_finds_pair_in_large_packing():
    """102 400 disks on a square lattice, touching. The search is binned (O(N)); a pairwise one
    would take minutes here. How long it takes is not asserted: timings stay out of the tests."""
    n_side = 320
    i, j = np.meshgrid(np.arange(n_side), np.arange(n_side), indexing="ij")
    x, y = (i.ravel() * D_S).astype(float), (j.ravel() * D_S).astype(float)
    rows = [{"x": a, "y": b, "diameter": D_S, "mass": M_S}
            for a, b in zip(x.tolist(), y.tolist(), strict=True)]
    d = {"scene": {"name": "big", "kind": "free"}, "particles": rows}
    scene = scene_from_dict(d)
    assert scene.n_free == n_side**2
    rows[50_000]["y"] = rows[50_001]["y"] - 0.2 * D_S  # deep overlap with its lattice neighbour
    with pytest.raises(SceneError, match=r"#50000 and #50001 overlap"):
        scene_from_dict(d)


def test_free_defaults_and_readonly_arrays():
    s = scene_from_dict(free_dict())
    assert s.geometry is None and s.species == () and s.averaging is None
    assert s.neighbors.skin is None and s.time.dt is None
    assert s.particles.vy.tolist() == [0.0, 0.0] and s.particles.omega.dtype == np.float64
    assert s.effects.normal_damping and s.effects.rotation and not s.effects.clip_attractive_normal
    assert s.n_free == 2 and s.min_free_diameter == D_S
    with pytest.raises(ValueError):
        s.particles.x[0] = 1.0
    assert s == scene_from_dict(free_dict()) and hash(s) == hash(scene_from_dict(free_dict()))


def test_couette_defaults_and_ints_become_floats():
    s = scene_from_dict(mutate(couette_dict(), "contact.k_n", 352))
    assert isinstance(s.contact.k_n, float) and s.contact.k_n == 352.0
    assert s.geometry.inner_radius == 0.1035 and s.geometry.outer_start_radius == 0.33
    assert s.contact.mu_bottom == 2e-5 and s.output.snapshot_interval == 1.0
    assert s.n_free == 2939 and s.min_free_diameter == D_S and s.particles is None
    assert scene_from_dict({**couette_dict(), "neighbors": {"skin": 1e-4}}).neighbors.skin == 1e-4


@pytest.mark.parametrize("path", RUN_SCRIPTS, ids=[p.name for p in RUN_SCRIPTS])
def test_shipped_scenes_load(path):
    s = load_scene(path)
    assert s.info.kind == "couette" and s.source == str(path)
    assert s.averaging is not None and s.averaging.weighting == "slice"
    assert resolve_dt(s) > 0


def test_shipped_scene_values():
    names = {p.stem for p in RUN_SCRIPTS}
    assert {"couette_A", "couette_B", "couette_C", "couette_quick"} <= names
    counts = {"A": (2511, 400), "B": (2545, 394), "C": (2555, 399)}
    for k, (ns, nl) in counts.items():
        s = load_scene(ROOT / "run_scripts" / "scenes" / f"couette_{k}.toml")
        assert s.info.name == f"couette-{k}"
        assert [(sp.count, sp.diameter, sp.mass) for sp in s.species] == [(ns, D_S, M_S),
                                                                          (nl, D_L, M_L)]
        assert s.time.end == 239.0 and (s.averaging.start, s.averaging.end) == (180.0, 239.0)
        assert s.averaging.reference_diameter == 8.0e-3  # the paper's d~ (Table 1.1)
    q = load_scene(ROOT / "run_scripts" / "scenes" / "couette_quick.toml")
    b = load_scene(ROOT / "run_scripts" / "scenes" / "couette_B.toml")
    # the quick scene is B's cell, shorter, with the wall layout it had when its state digest
    # was stored (tests/test_regression.py): 160 + 159 disks; B carries the calibrated one
    assert q.species == b.species and q.contact == b.contact
    assert (q.geometry.inner_wall_count, q.geometry.outer_wall_count) == (160, 159)
    assert dataclasses.replace(q.geometry, inner_wall_count=b.geometry.inner_wall_count,
                               outer_wall_count=b.geometry.outer_wall_count) == b.geometry
    assert q.time.end == 6.0 and q.averaging.sample_interval == 0.05


@pytest.mark.parametrize("maker", ["couette", "free", "B", "two_small"])
def test_toml_round_trip(tmp_path, maker):
    if maker == "couette":
        d = couette_dict()
        d["species"][0]["name"] = 'odd "small" \\ with\tcontrol ü'  # escaped in TOML
        s = scene_from_dict({**d, "averaging": {"weighting": "exact"}})
    elif maker == "free":
        d = free_dict()
        d["particles"][0].update(x=-0.1 / 3, omega=1e-300)
        d["scene"]["name"] = 'odd "name" ü'  # a name: no path separators or control characters
        d["time"]["dt"] = 1.234567890123e-5
        s = scene_from_dict(d)
    elif maker == "B":
        s = load_scene(ROOT / "run_scripts" / "scenes" / "couette_B.toml")
    else:
        s = load_scene(ROOT / "tests" / "scenes" / "two_small.toml")
    out = tmp_path / "scene.toml"
    write_scene(s, out)
    assert not (tmp_path / "scene.toml.tmp").exists()
    back = load_scene(out)
    assert back.to_dict() == s.to_dict()
    assert back.fingerprint() == s.fingerprint()
    assert back == s
    assert scene_to_toml(back) == scene_to_toml(s)


def test_to_dict_layout():
    d = scene_from_dict(free_dict()).to_dict()
    assert d["time"]["dt"] == "auto" and d["neighbors"]["skin"] == "auto"
    assert d["particles"][1] == {"x": 5e-3, "y": 0.0, "vx": -0.05, "vy": 0.0, "omega": 0.0,
                                 "diameter": D_S, "mass": M_S}
    assert "geometry" not in d and "species" not in d and "averaging" not in d
    c = scene_from_dict(couette_dict()).to_dict()
    assert c["species"][1]["count"] == 394 and "particles" not in c


def test_fingerprint_sensitivity():
    base = scene_from_dict(couette_dict()).fingerprint()
    assert len(base) == 64
    assert scene_from_dict(mutate(couette_dict(), "contact.k_n", 352.2)).fingerprint() != base
    assert scene_from_dict(mutate(couette_dict(), "scene.seed", 3)).fingerprint() != base
    assert scene_from_dict(mutate(couette_dict(), "time.integrator",
                                  "verlet-halfstep")).fingerprint() != base
    same = [mutate(couette_dict(), "time.end", 500.0), mutate(couette_dict(), "scene.name", "z"),
            mutate(couette_dict(), "time.integrator", "verlet"),  # the default: as before the key
            {**couette_dict(), "output": {"snapshot_interval": 0.2, "contacts": False}},
            {**couette_dict(), "averaging": {"start": 1.0, "end": 2.0}}]
    for d in same:
        assert scene_from_dict(d).fingerprint() == base


def test_particles_file_csv_and_h5(tmp_path):
    rng = np.random.default_rng(4)
    n = 30
    cols = {"x": np.arange(n) * 0.01, "y": rng.uniform(-1, 1, n), "vx": rng.normal(size=n),
            "vy": rng.normal(size=n), "omega": rng.normal(size=n),
            "diameter": np.where(np.arange(n) % 3, D_S, D_L), "mass": np.full(n, M_S)}
    rows = [{k: float(cols[k][i]) for k in cols} for i in range(n)]
    ref = scene_from_dict({"scene": {"name": "f", "kind": "free"}, "particles": rows})
    lines = [",".join(cols)] + [",".join(repr(float(cols[k][i])) for k in cols)
                                for i in range(n)]
    (tmp_path / "init.csv").write_text("\n".join(lines) + "\n")
    with h5py.File(tmp_path / "init.h5", "w") as f:
        for k, v in cols.items():
            f[k] = v
    for name in ("init.csv", "init.h5"):
        text = f'particles_file = "{name}"\n[scene]\nname = "f"\nkind = "free"\n'
        (tmp_path / "s.toml").write_text(text)
        s = load_scene(tmp_path / "s.toml")
        assert s.particles == ref.particles
        assert s.to_dict() == ref.to_dict() and s.fingerprint() == ref.fingerprint()


def test_particles_file_errors(tmp_path):
    def load(name, body=None):
        if body is not None:
            (tmp_path / name).write_text(body)
        return scene_from_dict({"scene": {"name": "f", "kind": "free"}, "particles_file": name},
                               base_dir=tmp_path)

    with pytest.raises(SceneError, match=r"particles_file = 'nope.csv': no such file"):
        load("nope.csv")
    with pytest.raises(SceneError, match=r"required column 'mass' missing"):
        load("a.csv", "x,y,diameter\n0,0,0.007\n")
    with pytest.raises(SceneError, match=r"unknown column 'z'"):
        load("b.csv", "x,y,z,diameter,mass\n0,0,0,0.007,0.0003\n")
    with pytest.raises(SceneError, match=r"row #1 diameter = -0.007: must be > 0"):
        load("c.csv", "x,y,diameter,mass\n0,0,0.007,0.0003\n1,0,-0.007,0.0003\n")
    with pytest.raises(SceneError, match=r"header row and at least one particle"):
        load("d.csv", "x,y,diameter,mass\n")
    with pytest.raises(SceneError, match=r"unreadable CSV"):
        load("e.csv", "x,y,diameter,mass\n0,zero,0.007,0.0003\n")
    with pytest.raises(SceneError, match=r"expected a .csv or .h5"):
        load("f.txt", "x\n")
    with pytest.raises(SceneError, match=r"column 'x' appears more than once in the header"):
        load("g.csv", "x,y,x,diameter,mass\n0,0,1,0.007,0.0003\n")
    with pytest.raises(SceneError, match=r"particles_file = 'h.h5': not a readable HDF5 file"):
        load("h.h5", "x,y\n0,0\n")  # text under an .h5 name
    import h5py

    with h5py.File(tmp_path / "i.h5", "w") as f:
        f["x"] = np.array([b"a", b"b"])
    with pytest.raises(SceneError, match=r"particles_file = 'i.h5': 'x' holds \|S1 values; "
                                         r"expected numbers"):
        load("i.h5")


def test_load_scene_file_errors(tmp_path):
    with pytest.raises(SceneError, match=re.escape(str(tmp_path / "missing.toml"))):
        load_scene(tmp_path / "missing.toml")
    bad = tmp_path / "scene.toml"
    bad.write_text("[scene\nkind = 'free'\n")
    with pytest.raises(SceneError, match=r"scene.toml: malformed TOML: "):
        load_scene(bad)
    bad.write_text("[scene]\nkind = 'couette'\n[[species]]\nname='s'\ndiameter=0.007\n"
                   "mass=1e-3\ncount=10\n[contact]\nk_n = -1.0\n")
    with pytest.raises(SceneError, match=re.escape("[contact] k_n = -1.0: must be > 0 (N/m)")):
        load_scene(bad)
    bad.write_text("[scene]\nkind = 'couette'\n[[species]]\nname='s'\ndiameter=0.007\n"
                   "mass=1e-3\ncount=10\n")
    assert load_scene(bad).info.name == "scene"  # name defaults to the file stem


def test_analytic_contact_values():
    for m, t_c, e_n in ((M_S, 2.177e-3, 0.2223), (M_L, 2.769e-3, 0.3417)):
        # SPEC values are rounded to 4 digits
        assert contact_time(352.1, 0.19, m / 2) == pytest.approx(t_c, abs=0.5e-6)
        assert restitution(352.1, 0.19, m / 2) == pytest.approx(e_n, abs=0.5e-4)
    assert restitution(352.1, 0.0, M_S) == 1.0
    with pytest.raises(SceneError, match=r"\[contact\] gamma_n = 10.0: overdamped"):
        contact_time(352.1, 10.0, M_S / 2)


def test_resolve_dt_shipped_b():
    s = load_scene(ROOT / "run_scripts" / "scenes" / "couette_B.toml")
    m_red = M_S / 2
    eta = 0.19 / (2 * m_red)
    t_c = math.pi / math.sqrt(352.1 / m_red - eta**2)  # hand formula, SPEC §3
    assert t_c == pytest.approx(2.177e-3, rel=1e-3)
    assert smallest_contact_time(s) == pytest.approx(t_c, rel=1e-12)
    # the step divides the time quantum, the power of ten of at least 100 steps of t_c/50
    # (4.35 ms: 10 ms), into the fewest steps no longer than t_c/50
    n = math.ceil(0.01 / (t_c / 50))
    assert n == 230
    assert resolve_step(s) == Fraction(1, 100 * n)
    assert resolve_dt(s) == pytest.approx(t_c / 50, rel=0.01)


@pytest.mark.parametrize("longest, quantum", [(4.353e-5, Fraction(1, 100)),
                                              (1e-4, Fraction(1, 100)),
                                              (1.01e-4, Fraction(1, 10)),
                                              (3e-9, Fraction(1, 10**6))])
def test_the_time_quantum_is_a_power_of_ten_of_at_least_100_steps(longest, quantum):
    assert time_quantum(longest) == quantum


def test_output_times_off_the_step_are_named_and_rounded():
    """B's output times (239 s, 1 s, 10 s, 180 s, 0.1 s) are whole numbers of 10 ms / 230
    steps; 0.3333333 s is not; with an explicit dt of 3e-5 s only 180 s is."""
    d = tomllib.loads((ROOT / "run_scripts" / "scenes" / "couette_B.toml").read_text())
    b = scene_from_dict(d)
    assert off_step(b, resolve_step(b)) == []
    assert "output at exactly the times named" in describe(b)
    odd = scene_from_dict(mutate(d, "output.snapshot_interval", 0.3333333))
    assert resolve_step(odd) == resolve_step(b)  # output settings never change the step
    assert off_step(odd, resolve_step(odd)) == ["[output] snapshot_interval = 0.333333 s"]
    assert "rounded to the nearest step: [output] snapshot_interval" in describe(odd)
    explicit = scene_from_dict(mutate(d, "time.dt", 3e-5))
    assert resolve_step(explicit) == Fraction(3, 100000)
    assert off_step(explicit, resolve_step(explicit)) == [  # only 180 s is whole (6e6 steps)
        "[time] end = 239 s", "[output] snapshot_interval = 1 s",
        "[output] checkpoint_interval = 10 s", "[averaging] end = 239 s",
        "[averaging] sample_interval = 0.1 s"]
    assert off_step(*(lambda s: (s, resolve_step(s)))(scene_from_dict(mutate(d, "time.dt",
                                                                             4e-5)))) == []


def test_the_step_is_limited_by_the_stiffest_enabled_contact_mode():
    """The largest stable step of the stiffest mode of the densest packing (hexagonal, six
    contacts per disk) of the small disks (m_red = 1.375e-4 kg), and never above t_c/5. One
    mode under pardem's Verlet turns unstable where W^2 dt^2 + 4 c dt = 4 (W^2: the position
    spring plus twice the explicitly incremented one, c: the damping rate;
    tests/hard/test_stability_hard.py checks this on the amplification matrix and measures
    the limit on a packing). Damped translation with friction: W^2 = 3 (k_n + 2 k_t)/m_red,
    c = 3 gamma_n/m_red: 0.19630 ms = t_c/11.09; without friction W^2 = 3 k_n/m_red: 0.21899
    ms; undamped with rotation the gears (all disks turning alike), W^2 = 2 x 12 k_t/m_red:
    0.29291 ms; undamped without rotation t_c/5 (undamped t_c 1.9632 ms) resolves collisions
    first. (t_c/5.1 with rotation off heated a packing 100x: issue 51.)"""
    def scene(**changes):
        d = couette_dict()
        for path, value in changes.items():
            d = mutate(d, path, value)
        return scene_from_dict(d)

    def step(w2, c):
        return 2 * (math.sqrt(c * c + w2) - c) / w2

    m_red, k_n, k_t, gamma = M_S / 2, 352.1, 267.1, 0.19
    damped_friction = step(3 * (k_n + 2 * k_t) / m_red, 3 * gamma / m_red)
    assert damped_friction == pytest.approx(1.9630e-4, rel=1e-4)
    with pytest.raises(SceneError) as err:
        resolve_dt(scene(**{"time.dt": 0.001}))
    msg = str(err.value)
    # 0.00019629 s printed rounded down, so that the printed limit is itself accepted
    assert msg.startswith("[time] dt = 0.001: dt exceeds the stability limit 0.0001962 s = "
                          "t_c/11.1, set by the densest packing's translation")
    assert "dt_per_contact >= 11.1" in msg
    assert resolve_dt(scene(**{"time.dt": 1.962e-4})) == 1.962e-4
    with pytest.raises(SceneError, match=r"\[time\] dt = 0.0001964: dt exceeds"):
        resolve_dt(scene(**{"time.dt": 1.964e-4}))
    # t_c/10 = 0.21765 ms, shortened to divide the 0.1 s quantum: 0.1 s / 460
    with pytest.raises(SceneError, match=r"\[time\] dt_per_contact = 10 \(dt = 0.0002174 s\)"):
        resolve_dt(scene(**{"time.dt_per_contact": 10}))
    assert resolve_dt(scene(**{"time.dt_per_contact": 11.2})) == pytest.approx(0.1 / 515,
                                                                              rel=1e-12)
    from pardem.core.stability import stability_limit

    for off in ({"effects.rotation": False}, {}):  # rotation changes nothing here
        assert stability_limit(scene(**off))[0] == pytest.approx(damped_friction, rel=1e-12)
    frictionless = step(3 * k_n / m_red, 3 * gamma / m_red)
    assert stability_limit(scene(**{"effects.tangential_friction": False}))[0] == \
        pytest.approx(frictionless, rel=1e-12)
    # mu = 0: the tangential spring never sticks, k_t = 0 has no mode (no division by zero)
    assert stability_limit(scene(**{"contact.mu": 0.0, "contact.k_t": 0.0}))[0] == \
        pytest.approx(frictionless, rel=1e-12)
    gears, what = stability_limit(scene(**{"effects.normal_damping": False}))
    assert gears == pytest.approx(2 / math.sqrt(24 * k_t / m_red), rel=1e-12)
    assert what.startswith("the densest packing's disks turning alike (gears)")
    t_c0 = math.pi * math.sqrt(m_red / k_n)
    resolution, what = stability_limit(scene(**{"effects.normal_damping": False,
                                                "effects.rotation": False}))
    assert resolution == pytest.approx(t_c0 / 5, rel=1e-12) and what.startswith("a collision's")
    # the rolling spring between two small disks: a' = a/2, I = m a^2/2, k_r a'^2 (1/I_i +
    # 1/I_j) = k_r/m (small-large gives 0.83 k_r/m_small), six of them; on the flat ring
    # surface a' = a and the ring does not turn: 2 k_r/m, plus four neighbours: also 6 k_r/m.
    # An explicit spring: sqrt(2)/omega. k_r = 1e4 N/m: 0.09574 ms
    rolling = scene(**{"effects.rolling_resistance": True, "contact.k_r": 1e4,
                       "contact.mu_r": 0.1})
    limit, what = stability_limit(rolling)
    assert limit == pytest.approx(math.sqrt(2) / math.sqrt(6e4 / M_S), rel=1e-12)
    assert what.startswith("the rolling spring")


def test_reduced_mass_rules():
    def couette(species):
        return scene_from_dict({**couette_dict(), "species": species})

    small = {"name": "small", "diameter": D_S, "mass": M_S, "count": 1}
    large = {"name": "large", "diameter": D_L, "mass": M_L, "count": 5}
    assert smallest_reduced_mass(couette([small, large])) == pytest.approx(M_S * M_L / (M_S + M_L))
    assert smallest_reduced_mass(couette([{**small, "count": 2}, large])) == M_S / 2
    assert smallest_reduced_mass(couette([{**small, "count": 0}, large])) == M_L / 2
    assert smallest_reduced_mass(couette([small])) == M_S  # only wall partners
    d = free_dict()
    d["particles"][1]["mass"] = M_L
    assert smallest_reduced_mass(scene_from_dict(d)) == pytest.approx(M_S * M_L / (M_S + M_L))
    no_damp = mutate(couette_dict(), "effects.normal_damping", False)
    assert smallest_contact_time(scene_from_dict(no_damp)) == pytest.approx(
        math.pi * math.sqrt(M_S / 2 / 352.1))


def test_free_particles_equality():
    a = scene_from_dict(free_dict()).particles
    b = FreeParticles(*(getattr(a, k).copy() for k in ("x", "y", "vx", "vy", "omega",
                                                       "diameter", "mass")))
    assert a == b and hash(a) == hash(b) and isinstance(a, FreeParticles)
    assert isinstance(scene_from_dict(free_dict()), Scene)


def test_filling_to_a_volume_fraction_gives_the_papers_counts():
    """B's cell filled to the paper's v-bar = 0.8149 (Table 1.1) with the paper's mixture gives
    the paper's 2545 small and 394 large disks. The paper's v-bar refers to a cell area of
    0.16670 m^2, ours (pi (R_o^2 - R_i^2) with the radii we use) is 0.166643 m^2, hence the
    factor (see test_plots.test_global_volume_fraction_of_the_paper_scenes)."""
    b = load_scene(ROOT / "run_scripts" / "scenes" / "couette_B.toml")
    d = b.to_dict()
    d["geometry"]["volume_fraction"] = 0.8149 * 0.16670 / 0.166643
    for s, share in zip(d["species"], (0.866, 0.134)):  # 2545 / 2939, 394 / 2939
        del s["count"]
        s["share"] = share
    filled = scene_from_dict(d)
    assert [s.count for s in filled.species] == [2545, 394]
    assert filled.fingerprint() == b.fingerprint()  # the resolved scene is B's


@pytest.mark.parametrize("geometry, species, message", [
    ({"volume_fraction": 0.8}, {"count": 10, "share": 1.0}, "count = 10: not allowed with"),
    ({"volume_fraction": 0.8}, {}, "share: missing (required with [geometry] volume_fraction)"),
    ({}, {"share": 1.0}, "share = 1.0: needs [geometry] volume_fraction"),
    ({}, {}, "count: missing (required, or [geometry] volume_fraction"),
    ({"volume_fraction": 0.001}, {"share": 1.0}, "the wall disks alone fill"),
    ({"volume_fraction": 0.91}, {"share": 1.0},  # one size: pi / (2 sqrt 3) = 0.906900 at most
     "[geometry] volume_fraction = 0.91: above 0.9069, the densest packing of equal disks"),
])
def test_volume_fraction_and_counts_errors(geometry, species, message):
    d = {"scene": {"kind": "couette"}, "geometry": geometry,
         "species": [{"name": "s", "diameter": 7.42e-3, "mass": 2.75e-4, **species}]}
    with pytest.raises(SceneError, match=re.escape(message)):
        scene_from_dict(d)


def test_overlap_check_with_a_few_much_larger_disks_equals_brute_force():
    """Disks over 4x the median diameter are checked against every disk, outside the cell grid
    (which would otherwise take the large diameter as its cell side): the same verdict as
    comparing every pair, for scenes with and without overlaps involving the large disks."""
    from pardem.input.particles import _worst_pair

    rng = np.random.default_rng(5)
    for trial in range(40):
        n = 300
        x, y = rng.uniform(0, 0.05, n), rng.uniform(0, 0.05, n)
        d = np.full(n, 1e-3)
        d[:3] = rng.uniform(0.01, 0.03, 3)  # three large disks
        dist = np.hypot(x[:, None] - x[None], y[:, None] - y[None])
        over = 0.5 * (d[:, None] + d[None]) - dist > 0.01 * np.minimum(d[:, None], d[None])
        np.fill_diagonal(over, False)
        pair = _worst_pair(x, y, d)
        assert (pair is None) == (not over.any()), trial
        if pair is not None:
            assert pair[0] < pair[1] and over[pair], trial
    # none overlapping: small disks on a lattice, one large disk away from them
    g = np.arange(400)
    x, y = np.append((g % 20) * 1.2e-3, -0.6), np.append((g // 20) * 1.2e-3, 0.0)
    d = np.append(np.full(400, 1e-3), 1.0)
    assert _worst_pair(x, y, d) is None
    x[-1] = -0.499  # now it reaches the first column of the lattice
    assert _worst_pair(x, y, d) == (0, 400)


def test_a_free_disk_that_would_skip_a_partner_in_one_step_is_refused():
    """Two free disks may meet at most at 0.25 d/(delta_max/u + dt) = 4.543 m/s, delta_max/u =
    0.3648 ms the damped collision's deepest overlap per approach speed (sqrt(m_red/k_n) = 0.6249
    ms times exp(-eta t*) = 0.584), dt = 10 ms / 230 = 4.348e-5 s (t_c/50 shortened to divide
    10 ms): the overlap then stays under 25 % of d (tests/hard/test_stability_hard.py runs it);
    the two fastest disks' speeds are summed. A disk's rim (velocity plus spin) may move at
    most half its diameter per step: 0.5 x 7.42e-3 / 4.348e-5 = 85.3 m/s; vx = 1e200
    overflowed the neighbour search. Huge masses only at tiny speeds (1e9 kg: 1.6e-6 m/s at
    dt = 1e-5 s, the damping negligible)."""
    d = free_dict()
    ok = scene_from_dict(mutate(d, "particles.1.vx", -4.45))  # 4.5 m/s with the other's 0.05
    assert 0.99 * 2.1765e-3 / 50 <= resolve_dt(ok) <= 2.1765e-3 / 50
    for value, speed in ((-4.5, "4.5"), (1e200, "1e+200")):
        message = (rf"free particles #1 and #0 \(0-based, in the order given\) move at "
                   rf"{re.escape(speed)} and 0.05 m/s: head on they would meet at .* disks "
                   r"may approach at up to 4.54 m/s")
        with pytest.raises(SceneError, match=message):
            resolve_dt(scene_from_dict(mutate(d, "particles.1.vx", value)))
    message = (r"free particle #1 \(0-based, in the order given\): moves at 85.4 m/s .*it "
               r"could pass through another disk between two steps; at most 85.3 m/s at this "
               r"dt")
    with pytest.raises(SceneError, match=message):  # 0.05 + 23000 a
        resolve_dt(scene_from_dict(mutate(d, "particles.1.omega", 23000.0)))
    heavy = mutate(mutate(d, "particles.0.mass", 1e9), "particles.1.mass", 1e9)
    slow = mutate(mutate(heavy, "particles.0.vx", 7e-7), "particles.1.vx", -7e-7)
    assert resolve_dt(scene_from_dict(mutate(slow, "time.dt", 1e-5))) == 1e-5
    with pytest.raises(SceneError, match="disks may approach at up to 1.56e-06 m/s"):
        resolve_dt(scene_from_dict(mutate(heavy, "time.dt", 1e-5)))

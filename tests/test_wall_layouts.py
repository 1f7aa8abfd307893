"""Per-ring wall layouts: how many glued disks, of which diameter, and whether the flat ring
surface behind them is a contact surface (SPEC §2; walls.WallLayout)."""

import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import couette_scene
from mpi_helpers import assert_same_state, dump_state

from pardem.input.placement import initial_configuration
from pardem.input.scene_file import load_scene, write_scene
from pardem.simulation import Simulation
from pardem.core.state import FREE, INNER_WALL, OUTER_WALL
from pardem.boundaries.walls import wall_layout

ROOT = Path(__file__).parents[1]
FAST = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
        "compression_time": 0.1, "omega_inner": 10.0}
# the study's layout kinds, scaled to the small fast cell (2.5 mm wall disks)
SMALL_LAYOUTS = {
    "both-7mm": {},
    "split": {"inner_wall_count": 77, "outer_wall_count": 57},
    "inner-only": {"inner_wall_count": 154, "outer_wall_count": 0},
    "outer-only": {"inner_wall_count": 0, "outer_wall_count": 113},
    "both-7mm-bare": {"inner_flat_surface": False, "outer_flat_surface": False},
}


def test_the_shipped_scenes_carry_the_calibrated_layout():
    """docs/roughness.md calibrates the inner ring's disk count on B's v0 alone, the outer ring
    taking the rest of the paper's 319 (v-bar_wall = 0.0047): A, B and C ship that layout, of
    2.5 mm disks with flat surfaces behind. The quick scene keeps its own (its state digest is
    a regression reference)."""
    found = re.search(r"\*\*Calibrated: N_in = (\d+)\.\*\*",
                      (ROOT / "docs" / "roughness.md").read_text())
    assert found, "docs/roughness.md states no calibrated N_in"
    n_in = int(found.group(1))
    for sim in ("A", "B", "C"):
        g = load_scene(ROOT / "run_scripts" / "scenes" / f"couette_{sim}.toml").geometry
        inner, outer = wall_layout(g, "inner"), wall_layout(g, "outer")
        assert (inner.count, outer.count) == (n_in, 319 - n_in), sim
        assert inner.diameter == outer.diameter == 2.5e-3 and inner.flat and outer.flat


def test_the_studys_layouts_have_the_papers_wall_fraction():
    """v-bar_wall = 0.0047 (the paper: half of every 2.5 mm wall disk over the cell area)."""
    sys.path.insert(0, str(ROOT / "run_scripts" / "studies"))
    import roughness_study

    for name in roughness_study.LAYOUTS:
        scene = roughness_study.scene_for("B", name, 1)
        g = scene.geometry
        n = wall_layout(g, "inner").count + wall_layout(g, "outer").count
        frac = n * 0.5 * math.pi * 1.25e-3**2 / (math.pi * (0.2525**2 - 0.1035**2))
        assert abs(frac - 0.0047) <= 0.00005, name
        assert roughness_study.wall_fraction(scene) == pytest.approx(frac, rel=1e-12)


def test_overlapping_wall_disks_are_placed_on_the_ring_line():
    scene = couette_scene(counts=(260, 40), geometry={**FAST, "inner_wall_count": 154,
                                                      "outer_wall_count": 0,
                                                      "inner_wall_diameter": 3e-3})
    init = initial_configuration(scene)
    inner = init.kind == INNER_WALL
    assert inner.sum() == 154 and not (init.kind == OUTER_WALL).any()
    assert np.allclose(np.hypot(*init.x[inner].T), 0.05, rtol=0, atol=1e-15)
    assert np.all(init.radius[inner] == 1.5e-3)
    gaps = np.diff(np.sort(np.arctan2(init.x[inner, 1], init.x[inner, 0]))) * 0.05
    assert gaps.max() < 3e-3  # 2.04 mm apart: neighbours overlap
    free = init.kind == FREE
    d = np.linalg.norm(init.x[free][:, None] - init.x[inner][None], axis=-1)
    assert np.all(d > init.radius[free][:, None] + 1.5e-3)  # no free disk starts in contact


@pytest.mark.parametrize("ring", ["inner", "outer"])
def test_a_ring_without_its_flat_surface_touches_only_through_its_disks(ring):
    """After the compression and some shear, disks press on the ring: through its wall disks
    only, none beyond the ring line, and no flat-surface contact with it."""
    scene = couette_scene(counts=(260, 40), geometry={**FAST, f"{ring}_flat_surface": False},
                          time={"end": 0.3})
    sim = Simulation(scene)
    sim.run(progress=False)
    kind = INNER_WALL if ring == "inner" else OUTER_WALL
    flat = sim.ring_contacts()
    assert not np.any(flat["ring"] == (1 if ring == "inner" else 2))
    assert np.any(flat["ring"] == (2 if ring == "inner" else 1))  # the other ring's surface
    ids = sim.contacts()["ids"]
    ps = sim.particle_arrays()
    assert np.sum(ps["kind"][ids[:, 1]] == kind) >= 10
    r = np.hypot(*ps["position"][ps["kind"] == FREE].T)
    assert r.min() > 0.05 and r.max() < 0.09


def test_a_smooth_ring_has_no_disks_and_takes_the_load_on_its_surface():
    scene = couette_scene(counts=(260, 40), geometry={**FAST, "inner_wall_count": 0},
                          time={"end": 0.3})
    sim = Simulation(scene)
    sim.run(progress=False)
    ps = sim.particle_arrays()
    assert not np.any(ps["kind"] == INNER_WALL)
    assert np.sum(sim.ring_contacts()["ring"] == 1) >= 10
    r = np.hypot(*ps["position"][ps["kind"] == FREE].T)
    assert r.min() > 0.05 and r.max() < 0.09


@pytest.mark.parametrize("name", SMALL_LAYOUTS)
def test_every_layout_runs_bitwise_identically_on_1_and_2_ranks(tmp_path, name):
    """Compression and 0.13 s of fast shear, migrations included."""
    path = tmp_path / f"{name}.toml"
    write_scene(couette_scene(counts=(260, 40), geometry={**FAST, **SMALL_LAYOUTS[name]},
                              name=name, averaging={"start": 10.0, "end": 20.0,
                                                    "displacement": "eta"}), path)
    steps = 6000
    ref = dump_state(path, steps, tmp_path / "r1.npz", 1)
    got = dump_state(path, steps, tmp_path / "r2.npz", 2)
    assert got["migrated"] > 0
    assert ref["pair_hist"].shape[1] == 4  # eta averages: the spring and eta migrate, compare
    assert_same_state(ref, got, f"{name}: 2 ranks vs 1")

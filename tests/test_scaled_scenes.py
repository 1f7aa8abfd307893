"""The shipped scaled cells (run_scripts/scenes/couette_B_30k/_300k/_1M.toml) are B scaled by k at
fixed particle size: the free disks' area fraction and the wall disks' spacing are B's,
computed here from the files' own numbers, and each file is what scaled_scene.py writes; B with
a 10 times faster ring (couette_B_ring_x10.toml) has the 300k cell's wall speed."""

import math
import sys
import tomllib
from pathlib import Path

import pytest

RUN_SCRIPTS = Path(__file__).parents[1] / "run_scripts" / "scenes"
sys.path.insert(0, str(RUN_SCRIPTS.parent / "tools"))
from scaled_scene import fast_ring, scaled  # noqa: E402


def numbers(path: Path):
    d = tomllib.loads(path.read_text())
    g = d["geometry"]
    area = math.pi * (g["outer_radius"] ** 2 - g["inner_radius"] ** 2)
    free = sum(s["count"] * math.pi * s["diameter"] ** 2 / 4 for s in d["species"]) / area
    spacing = (2 * math.pi * g["inner_radius"] / g["inner_wall_count"],
               2 * math.pi * g["outer_radius"] / g["outer_wall_count"])
    return free, spacing, sum(s["count"] for s in d["species"])


@pytest.mark.parametrize("name,k,n", [("30k", 3.2, 30096), ("300k", 10, 293900),
                                      ("1M", 18.5, 1005872)])
def test_scaled_cells_keep_bs_packing_and_roughness(name, k, n):
    path = RUN_SCRIPTS / f"couette_B_{name}.toml"
    assert path.read_text() == scaled(k)
    free_b, spacing_b, n_b = numbers(RUN_SCRIPTS / "couette_B.toml")
    free, spacing, count = numbers(path)
    assert count == n == pytest.approx(n_b * k * k, abs=1)
    assert free == pytest.approx(free_b, rel=1e-4)  # counts rounded to integers
    assert spacing == pytest.approx(spacing_b, rel=2e-3)  # wall counts rounded too


def test_scaled_cells_start_as_tight_as_the_placement_allows():
    """The 30k cell's outer ring starts where the placement (pardem.input.placement) just fits every
    disk: it places them there, and refuses 0.5 % closer to the final radius."""
    import dataclasses

    from pardem.input.placement import initial_configuration
    from pardem.input.scene import SceneError
    from pardem.input.scene_file import load_scene

    scene = load_scene(RUN_SCRIPTS / "couette_B_30k.toml")
    assert initial_configuration(scene).n_free == 30096
    g = scene.geometry
    closer = dataclasses.replace(g, outer_start_radius=g.outer_start_radius - 0.005 * (
        g.outer_start_radius - g.inner_radius))
    with pytest.raises(SceneError, match="cannot place"):
        initial_configuration(dataclasses.replace(scene, geometry=closer))


def test_b_with_a_fast_ring_moves_its_wall_as_fast_as_the_300k_cell():
    """B as it is but for Omega and the protocol's times, which turn the ring as far."""
    fast = tomllib.loads((RUN_SCRIPTS / "couette_B_ring_x10.toml").read_text())
    b = tomllib.loads((RUN_SCRIPTS / "couette_B.toml").read_text())
    big = tomllib.loads((RUN_SCRIPTS / "couette_B_300k.toml").read_text())
    assert (RUN_SCRIPTS / "couette_B_ring_x10.toml").read_text() == fast_ring(10)
    speed = [d["geometry"]["omega_inner"] * d["geometry"]["inner_radius"] for d in (fast, big)]
    assert speed[0] == pytest.approx(speed[1], rel=1e-12) and speed[0] > 0
    turns = [d["geometry"]["omega_inner"] * d["time"]["end"] for d in (fast, b)]
    assert turns[0] == pytest.approx(turns[1], rel=1e-12)
    for table in ("species", "contact", "effects"):
        assert fast[table] == b[table]
    assert {k: v for k, v in fast["geometry"].items() if k != "omega_inner"} == {
        k: v for k, v in b["geometry"].items() if k != "omega_inner"}

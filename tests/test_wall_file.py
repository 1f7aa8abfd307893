"""The boundary of fixed wall disks from a user's file (pardem/boundaries/wall_file.py): a free disk
rebounds off one as off an infinitely massive partner (the analytic collision), the wall disk
never moves, a run holds its disks inside a container of them bit for bit alike on 1 and 2
ranks, and a bad file or table is refused naming the key and the problem."""

import math

import numpy as np
import pytest
from helpers import D_SMALL, GAMMA_N, K_N, M_SMALL, analytic_collision
from mpi_helpers import assert_same_state, dump_state

from pardem.input.schema import scene_from_dict
from pardem.input.scene import SceneError
from pardem.input.scene_file import load_scene, write_scene
from pardem.simulation import Simulation
from pardem.testing import measure

WALL_D = 2.5e-3  # m, the paper's wall disks
DAMPING_ONLY = {"normal_damping": True, "tangential_friction": False, "rotation": False,
                "bottom_friction": False, "clip_attractive_normal": False}


def free_scene(tmp_path, walls: list[tuple[float, float, float]], particles: list[dict],
               dt="auto", **extra) -> dict:
    """A free scene dict whose wall disks (x, y, diameter) are read from tmp_path/walls.csv."""
    (tmp_path / "walls.csv").write_text(
        "# fixed wall disks\nx,y,diameter\n" + "".join(f"{x!r},{y!r},{d!r}\n" for x, y, d in walls))
    return {"scene": {"name": "wall-file", "kind": "free", "seed": 1}, "particles": particles,
            "wall_disks_file": "walls.csv", "effects": DAMPING_ONLY,
            "contact": {"k_n": K_N, "gamma_n": GAMMA_N, "k_t": 0.0, "mu": 0.0},
            "time": {"dt": dt, "end": 1.0}, **extra}


def head_on(tmp_path, dt):
    """One small disk moving along -x into a fixed wall disk at the origin."""
    a, aw = D_SMALL / 2, WALL_D / 2
    particle = {"x": a + aw + 1e-4, "y": 0.0, "vx": -0.05, "diameter": D_SMALL, "mass": M_SMALL}
    sim = Simulation(scene_from_dict(free_scene(tmp_path, [(0.0, 0.0, WALL_D)], [particle], dt),
                                     base_dir=tmp_path))

    def overlap(s):
        x = s.gathered("position")["position"]
        return a + aw - np.hypot(*(x[0] - x[1]))
    return sim, overlap, lambda s: -s.gathered("velocity")["velocity"][0, 0]


def test_a_disk_rebounds_off_a_file_wall_disk_as_off_an_infinite_mass(tmp_path):
    tc, e = analytic_collision(M_SMALL)  # m_red = m for an infinitely massive partner
    sim, overlap, speed = head_on(tmp_path, "auto")
    assert sim.gathered("kind")["kind"].tolist() == [0, 3]  # free, then the fixed wall disk
    tcm, em = measure(sim, overlap, speed)
    assert abs(tcm / tc - 1) < 0.05 and abs(em / e - 1) < 0.05
    wall = sim.gathered("position", "velocity")
    assert wall["position"][1].tolist() == [0.0, 0.0] and wall["velocity"][1].tolist() == [0, 0]
    tcf, ef = measure(*head_on(tmp_path, tc / 2000))
    assert abs(tcf / tc - 1) < 1e-3 and abs(ef / e - 1) < 1e-3


def container(tmp_path) -> tuple[object, float, float]:
    """Small disks moving inside a closed ring of 64 fixed wall disks (radius R): the scene
    file, R and the run's length (s)."""
    big = 0.03
    phi = 2 * math.pi * np.arange(64) / 64
    walls = [(big * math.cos(p), big * math.sin(p), 4e-3) for p in phi]
    rng = np.random.default_rng(3)
    spots = [(x, y) for x in np.arange(-0.018, 0.019, 0.009) for y in np.arange(-0.018, 0.019, 0.009)
             if math.hypot(x, y) < 0.02]
    particles = [{"x": float(x), "y": float(y), "vx": float(v[0]), "vy": float(v[1]),
                  "diameter": D_SMALL, "mass": M_SMALL}
                 for (x, y), v in zip(spots, rng.normal(0.0, 0.3, (len(spots), 2)))]
    scene = scene_from_dict(free_scene(tmp_path, walls, particles), base_dir=tmp_path)
    path = tmp_path / "container.toml"
    write_scene(scene, path)  # the resolved scene holds the disks as [[wall_disks]] tables
    assert load_scene(path) == scene and scene.wall_disks.x.size == 64
    return path, big, 0.2


def test_a_container_of_file_wall_disks_runs_bitwise_alike_on_1_and_2_ranks(tmp_path):
    scene, big, length = container(tmp_path)
    sim = Simulation(load_scene(scene))
    steps = int(length / sim.dt)
    v0 = np.hypot(*sim.gathered("velocity")["velocity"][:sim.n_free].T)
    assert v0.max() * length > 2 * big  # without the walls the fastest disk would be out
    one = dump_state(scene, steps, tmp_path / "r1.npz", 1)
    two = dump_state(scene, steps, tmp_path / "r2.npz", 2)
    assert_same_state(one, two, "2 ranks vs 1")
    free = one["gid"] < sim.n_free
    assert np.hypot(*one["x"][free].T).max() < big  # every disk is still inside
    assert two["migrated"] > 0  # disks crossed between the ranks' sectors


@pytest.mark.parametrize("csv,where,problem", [
    (None, "wall_disks_file = 'walls.csv'", "no such file"),
    ("x,y,vx\n0.1,0.1,1e-3\n", "wall_disks_file = 'walls.csv'", "unknown column 'vx'"),
    ("x,y\n0.1,0.1\n", "wall_disks_file = 'walls.csv'", "required column 'diameter' missing"),
    ("x,y,diameter\n0.1,0.1,1e-3\n0.2,0.1,-1e-3\n", "wall_disks_file = 'walls.csv' row #1 "
     "diameter = -0.001", "must be > 0"),
    ("x,y,diameter\n0.1,nan,1e-3\n", "row #0 y = nan", "must be finite"),
    ("x,y,diameter\n0.0,0.005,4e-3\n", "wall_disks_file = 'walls.csv' row #0 and "
     "[[particles]] #0 overlap", "at most 1% allowed"),
])
def test_a_bad_wall_disk_file_is_refused_naming_the_key_and_the_problem(tmp_path, csv, where,
                                                                        problem):
    d = free_scene(tmp_path, [], [{"x": 0.0, "y": 0.0, "diameter": D_SMALL, "mass": M_SMALL}])
    (tmp_path / "walls.csv").unlink()
    if csv is not None:
        (tmp_path / "walls.csv").write_text(csv)
    with pytest.raises(SceneError) as err:
        scene_from_dict(d, base_dir=tmp_path)
    assert where in str(err.value) and problem in str(err.value)


def test_wall_disks_are_refused_in_a_couette_scene_and_twice(tmp_path):
    (tmp_path / "walls.csv").write_text("x,y,diameter\n0.15,0.0,1e-3\n")
    couette = {"scene": {"kind": "couette"}, "wall_disks_file": "walls.csv",
               "species": [{"name": "s", "diameter": D_SMALL, "mass": M_SMALL, "count": 10}]}
    with pytest.raises(SceneError, match="wall_disks_file = 'walls.csv': allowed in free scenes"):
        scene_from_dict(couette, base_dir=tmp_path)
    both = free_scene(tmp_path, [(0.1, 0.0, 1e-3)], [{"x": 0.0, "y": 0.0, "diameter": D_SMALL,
                                                     "mass": M_SMALL}])
    both["wall_disks"] = [{"x": 0.1, "y": 0.0, "diameter": 1e-3}]
    with pytest.raises(SceneError, match=r"\[\[wall_disks\]\] and wall_disks_file: give one"):
        scene_from_dict(both, base_dir=tmp_path)
    both.pop("wall_disks_file")
    both["wall_disks"][0]["z"] = 0.0
    with pytest.raises(SceneError, match=r"\[\[wall_disks\]\] #0 unknown key 'z'"):
        scene_from_dict(both, base_dir=tmp_path)

"""Scenes and files that once crashed a run or the machine, each refused with a message in the
user's terms or run through: a free scene's overlap warning, damaged and foreign checkpoints,
absurd wall-disk sizes, averaging that would not fit in memory, a size distribution that a
lattice spaced by its largest disk cannot hold, a million wall disks on one ring."""

import math

import h5py
import numpy as np
import pytest
from helpers import couette_scene, free_scene

from pardem.cli import main
from pardem.core import memory
from pardem.input.placement import initial_configuration
from pardem.input.scene import SceneError
from pardem.input.scene_file import write_scene
from pardem.input.schema import scene_from_dict
from pardem.simulation import Simulation

D, M = 7.42e-3, 0.275e-3  # the paper's small disk (m, kg)


def head_on(speed, restitution=0.8):
    """Two small disks 20.5 mm apart closing at 2 x ``speed`` (m/s), linear law."""
    disks = [{"x": -10.25e-3, "y": 0.0, "vx": speed, "vy": 0.0, "omega": 0.0, "diameter": D,
              "mass": M},
             {"x": 10.25e-3, "y": 0.0, "vx": -speed, "vy": 0.0, "omega": 0.0, "diameter": D,
              "mass": M}]
    d = free_scene(disks, effects={"normal_damping": True},
                   contact={"gamma_n": None, "restitution": restitution},
                   time={"end": 0.02}).to_dict()
    # the overlap is measured whenever control returns to Python: at every snapshot here
    d["output"] = {"snapshot_interval": 2e-4, "checkpoint_interval": 0.01}
    return scene_from_dict(d)


def test_a_free_scene_whose_overlap_warning_fires_runs_to_its_end(tmp_path, capsys):
    """The damped spring's deepest overlap at impact speed v = 3 m/s: x = v/w0 exp(-z/sqrt(1 -
    z^2) atan(sqrt(1 - z^2)/z)), z the damping ratio of e = 0.8: 22.6 % of d, past the 5 %
    warning. The run warns (the free scene has no compression to name), ends with its
    checkpoint, and the disks leave at 0.8 of their closing speed."""
    k = 352.1
    w0 = math.sqrt(k / (M / 2))
    z = -math.log(0.8) / math.sqrt(math.pi**2 + math.log(0.8) ** 2)
    deepest = 3.0 / w0 * math.exp(-z / math.sqrt(1 - z * z) * math.atan(math.sqrt(1 - z * z) / z))
    assert 0.2 < deepest / D < 0.25
    sim = Simulation(head_on(1.5), out_dir=tmp_path)
    sim.run(progress=False)
    warned = capsys.readouterr().err
    found = [float(p) / 100 for p in __import__("re").findall(
        r"during the run: the largest overlap is (\S+) %", warned)]
    assert len(found) == 1 and 0.05 < found[0] <= deepest / D * 1.001
    assert (tmp_path / "checkpoint.h5").is_file()
    v = sim.particle_arrays()["velocity"]
    assert v[1, 0] - v[0, 0] == pytest.approx(0.8 * 3.0, rel=0.01)


# -- checkpoints ---------------------------------------------------------------------------

def small_cell():
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 1.0}
    return couette_scene(counts=(260, 40), geometry=g, time={"end": 0.2},
                         output={"checkpoint_interval": 0.05, "snapshot_interval": 0.05},
                         averaging={"start": 0.02, "end": 0.2, "sample_interval": 0.01,
                                    "ring_width": 2e-3})


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    """A checkpoint of small_cell at 0.05 s and the scene file it belongs to."""
    folder = tmp_path_factory.mktemp("ckpt")
    write_scene(small_cell(), folder / "cell.toml")
    sim = Simulation(small_cell(), out_dir=folder / "run")
    sim.run(end=0.05, progress=False)
    return folder / "run" / "checkpoint.h5", folder / "cell.toml"


def changed(checkpoint, path, **attrs):
    """A copy of the checkpoint at ``path`` with attributes set (None: deleted)."""
    path.write_bytes(checkpoint.read_bytes())
    with h5py.File(path, "a") as h5:
        for k, v in attrs.items():
            if v is None:
                del h5.attrs[k]
            else:
                h5.attrs[k] = v
    return path


def refused(scene, ckpt, option, tmp_path, capsys) -> str:
    """stderr of ``pardem run scene --restart|--from ckpt``, which must end with exit 2."""
    code = main(["run", str(scene), "--out", str(tmp_path / "out"), "--quiet", "--overwrite",
                 option, str(ckpt)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    return err


@pytest.mark.parametrize("option", ["--restart", "--from"])
def test_a_checkpoint_with_every_997th_byte_flipped_is_refused_by_name(
        checkpoint, tmp_path, capsys, option):
    ckpt, scene = checkpoint
    data = bytearray(ckpt.read_bytes())
    for i in range(996, len(data), 997):
        data[i] ^= 0xFF
    bad = tmp_path / "flipped.h5"
    bad.write_bytes(bytes(data))
    err = refused(scene, bad, option, tmp_path, capsys)
    assert f"{option} {bad}:" in err and ("corrupted" in err or "unreadable" in err)


@pytest.mark.parametrize("option", ["--restart", "--from"])
def test_one_flipped_bit_in_the_data_fails_the_checksum(checkpoint, tmp_path, capsys, option):
    """A bit of the positions' bytes flipped: still HDF5, still finite numbers, but not what
    was written."""
    ckpt, scene = checkpoint
    with h5py.File(ckpt, "r") as h5:
        offset = h5["x"].id.get_offset() + 8 * 17 + 3  # a mantissa byte of row 8's x
    data = bytearray(ckpt.read_bytes())
    data[offset] ^= 0x10
    bad = tmp_path / "bit.h5"
    bad.write_bytes(bytes(data))
    err = refused(scene, bad, option, tmp_path, capsys)
    assert "dataset 'x' does not match its checksum" in err


@pytest.mark.parametrize("option", ["--restart", "--from"])
@pytest.mark.parametrize("attrs, says", [
    ({"scene_physics": "{not json"}, "attribute 'scene_physics' is '{not json', expected JSON"),
    ({"version": "0.0.1"}, "format version '0.0.1' is not a whole number"),
    ({"version": 3}, "written by a later pardem (checkpoint format version 3)"),
    ({"step": -4}, "attribute 'step' is -4, expected a whole number >= 0"),
    ({"checksums": "[1, 2]"}, "attribute 'checksums' is '[1, 2]', expected a JSON object"),
    ({"end_snapshot": np.array([1, 2])}, "attribute 'end_snapshot' is array([1, 2]), expected 0"),
    ({"step": np.uint64(2**64 - 1)}, "attribute 'step' is 18446744073709551615, expected a whole"),
])
def test_a_foreign_checkpoint_attribute_is_refused_by_name(checkpoint, tmp_path, capsys,
                                                            option, attrs, says):
    ckpt, scene = checkpoint
    err = refused(scene, changed(ckpt, tmp_path / "c.h5", **attrs), option, tmp_path, capsys)
    assert says in err


@pytest.mark.parametrize("key", ["rings_sums", "rings_times", "rings_loads"])
def test_a_checkpoint_without_its_ring_samples_is_refused_by_name(checkpoint, tmp_path, capsys,
                                                                   key):
    ckpt, scene = checkpoint
    bad = tmp_path / "c.h5"
    bad.write_bytes(ckpt.read_bytes())
    with h5py.File(bad, "a") as h5:
        del h5[key]
        if key == "rings_loads":
            del h5["rings_inner_torque"]
    err = refused(scene, bad, "--restart", tmp_path, capsys)
    assert "corrupted checkpoint" in err and ("rings_sums" if key == "rings_sums" else
                                              "rings_times" if key == "rings_times"
                                              else "rings_loads") in err


def test_a_branch_from_a_checkpoint_without_its_scene_points_to_restart(
        checkpoint, tmp_path, capsys):
    ckpt, scene = checkpoint
    bad = changed(ckpt, tmp_path / "old.h5", scene_physics=None)
    err = refused(scene, bad, "--from", tmp_path, capsys)
    assert f"--from {bad}: the checkpoint does not record its scene" in err
    assert "continue it with --restart instead" in err


# -- scene limits --------------------------------------------------------------------------

@pytest.mark.parametrize("key", ["wall_particle_diameter", "inner_wall_diameter",
                                 "outer_wall_diameter"])
def test_a_wall_disk_of_1e300_m_is_refused_by_its_key(key):
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11, key: 1e300}
    with pytest.raises(SceneError, match=rf"\[geometry\] {key} = 1e\+300: .*smaller than the "
                                         r"annulus gap outer_radius - inner_radius = 0\.04 m"):
        couette_scene(counts=(260, 40), geometry=g)


def test_a_wall_spacing_of_1e_300_m_is_refused_with_the_count_it_gives():
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "wall_particle_spacing": 1e-300}
    # 2 pi 0.05 m / 1e-300 m = 3.14e299 disks on the inner ring
    with pytest.raises(SceneError, match=r"wall_particle_spacing = 1e-300: gives 3\.14e\+299 "
                                         r"wall disks on the inner ring"):
        couette_scene(counts=(260, 40), geometry=g)


def test_averaging_that_cannot_fit_in_memory_is_refused_before_the_run(tmp_path, monkeypatch,
                                                                        capsys):
    """100,000 rings sampled 591 times: every rank keeps 591 x 100,000 x 30 sums of 8 bytes
    (13.2 GiB) and stacks them once more to form the fields. On a node with 16 GiB free the
    run is refused at once, naming the averaging; ``check`` prints the estimate."""
    from averaging.fields import N_COLUMNS

    assert N_COLUMNS == 30
    monkeypatch.setattr(memory, "available_bytes", lambda: 16.0 * 2**30)
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11}
    d = couette_scene(counts=(260, 40), geometry=g, time={"end": 239.0}).to_dict()
    d["averaging"] = {"start": 180.0, "end": 239.0, "sample_interval": 0.1, "ring_width": 4e-7}
    scene = scene_from_dict(d)
    assert memory.averaging_shape(scene) == (591, 100_000)
    sums = 591 * 100_000 * 30 * 8.0
    assert 2 * sums < memory.averaging_bytes(scene) < 2 * sums + 2e9
    path = tmp_path / "rings.toml"
    write_scene(scene, path)
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "591 samples of 100000 rings" in err and "ring_width" in err
    assert not list((tmp_path / "o").glob("*.h5")) and not (tmp_path / "o" / "snapshots").exists()
    assert main(["check", str(path)]) == 0
    mesh = 100_000 * 3 * 2400.0  # rings.vtu: 3 segments a ring, ~2.4 kB a cell (measured)
    fields = 9 * 59 * 100_000 * 8.0  # 59 fields of the window and of its 8 blocks
    assert (f"{(2 * sums + fields + mesh) / 2**30:.3g} GiB for the averaging's 591 samples of 100000 "
            "rings" in capsys.readouterr().out)


def test_rings_vtu_of_many_rings_has_fewer_segments_and_every_ring():
    """The mesh of 10,000 rings keeps every ring's values with fewer segments per ring."""
    from averaging.mesh import MESH_CELLS, SEGMENTS, annulus, segments_for

    assert segments_for(161) == SEGMENTS  # the paper's cells: unchanged
    k = segments_for(10_000)
    assert 3 <= k < SEGMENTS and 10_000 * k <= MESH_CELLS
    points, quads = annulus(np.linspace(0.1, 0.2, 10_001), k)
    assert quads.shape == (10_000 * k, 4) and points.shape[0] == 10_001 * k


# -- placement -----------------------------------------------------------------------------

def lognormal_cell(count, start=0.12):
    """The review's scene: 300 log-normal disks (median 7 mm, sigma 0.2) in a small cell."""
    d = {"scene": {"name": "poly", "kind": "couette", "seed": 1},
         "geometry": {"inner_radius": 0.05, "outer_radius": 0.10, "outer_start_radius": start,
                      "compression_time": 1.0, "omega_inner": 1.0},
         "species": [{"name": "grains", "diameter_distribution": "lognormal",
                      "diameter_median": 7e-3, "diameter_sigma": 0.2, "density": 1060.0,
                      "count": count}],
         "time": {"end": 0.1}}
    return scene_from_dict(d)


def test_a_size_distribution_too_coarse_for_the_lattice_is_placed_by_its_own_sizes(
        tmp_path, capsys):
    """No two disks overlap and every disk lies between the rings clear of their wall disks
    (checked here from the positions and radii alone); ``check`` places it as run does."""
    scene = lognormal_cell(300)
    init = initial_configuration(scene)
    assert init.placement == "inserted"
    n = init.n_free
    x, a = init.x[:n], init.radius[:n]
    dist = np.hypot(*(x[:, None, :] - x[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(dist, np.inf)
    assert (dist >= a[:, None] + a[None, :]).all()
    r = np.hypot(x[:, 0], x[:, 1])
    wall = 2.5e-3 / 2
    assert (r - a >= 0.05 + wall).all() and (r + a <= 0.12 - wall).all()
    path = tmp_path / "poly.toml"
    write_scene(scene, path)
    assert main(["check", str(path)]) == 0
    assert "300, inserted at random by their own sizes" in capsys.readouterr().out


def test_check_refuses_a_count_the_start_cannot_hold(tmp_path, capsys):
    """500 disks of mean area pi/4 d_50^2 exp(2 sigma^2) = 4.17e-5 m^2 fill 0.885 of the
    annulus (allowed: below the whole cell), started compressed (outer_start_radius =
    outer_radius): far beyond what random insertion reaches (~0.55 for equal disks), and
    the lattice spaced by the largest disk holds fewer: no placement, in check as in run."""
    scene = lognormal_cell(500, start=0.10)
    path = tmp_path / "full.toml"
    write_scene(scene, path)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "cannot place 500 particles" in err and "random insertion" in err


def test_a_million_wall_disks_on_one_ring_set_up_and_step(tmp_path, capsys):
    """999,999 inner wall disks of 1 um, the review's scene that sat minutes in the first
    neighbour build: a wall disk's partners are free disks, found from their side, so the
    build no longer scans a million wall disks against each other. Its free disks are listed
    against them as before: a disk pushed onto the inner ring touches some."""
    g = {"inner_radius": 0.05, "outer_radius": 0.10, "outer_start_radius": 0.12,
         "compression_time": 1.0, "omega_inner": 1.0, "inner_wall_count": 999_999,
         "inner_wall_diameter": 1e-6, "outer_wall_count": 80}
    scene = couette_scene(counts=(326, 50), geometry=g, time={"end": 0.01})
    sim = Simulation(scene)
    sim.advance_steps(20)
    assert sim.step == 20 and np.isfinite(sim.particle_arrays()["position"]).all()
    # and the run time they cost is said before the run: 999,999 + 80 wall disks for 376 free
    path = tmp_path / "walls.toml"
    write_scene(scene, path)
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "the rings carry 1000079 wall disks for 376 free disks" in out
    assert "the estimate counts the rings' 1000079 wall disks, beyond the share" in out


def test_the_memory_table_of_the_manual_is_the_committed_measurement():
    """docs/running.md's table is generated from results/robustness/memory.json, and each
    estimate there lies within 30 % of the peak it was measured beside."""
    import json
    import sys
    from pathlib import Path

    root = Path(__file__).parents[1]
    sys.path.insert(0, str(root / "run_scripts" / "benchmarks"))
    from memory_estimate import PAGE, RESULTS, table

    rows = json.loads(RESULTS.read_text())
    assert {r["case"] for r in rows} == {"quick", "30k", "rings"}
    assert all(0.7 <= r["estimate_mib"] / r["peak_mib"] <= 1.3 for r in rows)
    assert table(rows) in PAGE.read_text()

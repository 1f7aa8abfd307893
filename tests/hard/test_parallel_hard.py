"""Hard cases of the decomposition and the watchdog: disk centres exactly on sector edges, a rank
whose sector holds no particle, a NaN or an escaped particle mid-run (serial and on 2 ranks)."""


import h5py
import numpy as np
import pytest
from helpers import couette_scene
from mpi_helpers import MPI_DIR, assert_same_state, dump_state, run_mpi

from averaging.weights import WEIGHTINGS, ring_weights
from pardem.input.scene_file import write_scene
from pardem.simulation import Simulation, SimulationError

CELL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.09,
        "compression_time": 0.0, "omega_inner": 3.0}


def test_disk_centres_exactly_on_sector_edges(tmp_path):
    """Two disks placed exactly on the rays where 2 ranks cut the annulus: exactly one rank owns
    each, and 1, 2 and 3 ranks give the same bits after 3000 steps."""
    scene = tmp_path / "edge.toml"
    write_scene(couette_scene(counts=(40, 0), geometry=CELL, name="edge"), scene)
    out = {}
    for n in (1, 2, 3):
        run_mpi([str(MPI_DIR / "edge_particles.py"), str(scene), "3000",
                 str(tmp_path / f"e{n}.npz")], n)
        with np.load(tmp_path / f"e{n}.npz") as f:
            out[n] = {k: f[k] for k in f.files}
        assert out[n]["owners"] == 1 and out[n]["owned"] == 40
    assert out[1]["x"][0, 0] != out[1]["edge_x"]  # it moved off the edge during the run
    for n in (2, 3):
        assert_same_state(out[1], out[n], f"{n} ranks vs 1 with disks on the sector edges")


def test_a_rank_with_an_empty_sector(tmp_path):
    """Three free particles on four ranks: at least one sector holds none; the run is the serial
    one bit for bit."""
    scene = tmp_path / "few.toml"
    write_scene(couette_scene(counts=(3, 0), geometry=CELL, name="few"), scene)
    ref = dump_state(scene, 2000, tmp_path / "r1.npz", 1)
    got = dump_state(scene, 2000, tmp_path / "r4.npz", 4)
    assert_same_state(ref, got, "4 ranks, an empty sector, vs 1")


def test_ring_edges_in_the_averaging():
    """Disk centres exactly on ring boundaries (every boundary of the paper's 160 rings, and the
    floats next to them) and disks whose rim touches one: for every weighting the weights are
    finite, non-negative and sum to 1 (a centre on an edge once lost its whole 'centre'
    weight: the ring index and the share were rounded differently)."""
    rings = np.zeros(64, np.int64)
    wts = np.zeros(64)
    r0, dr, a = 0.1035, 0.9275e-3, 3.71e-3
    edges = r0 + np.arange(1, 160) * dr
    centres = np.concatenate([edges, np.nextafter(edges, 0), np.nextafter(edges, 1),
                              edges + a, edges - a])
    for kind in WEIGHTINGS.values():
        for rho in centres:
            m = ring_weights(rho, a, r0, dr, 200, kind, rings, wts)
            assert np.all(np.isfinite(wts[:m])) and np.all(wts[:m] >= 0)
            assert wts[:m].sum() == pytest.approx(1.0, abs=1e-13), (kind, rho)


def small_run(tmp_path):
    scene = couette_scene(counts=(260, 40), geometry={**CELL, "outer_start_radius": 0.11,
                                                      "compression_time": 0.1},
                          output={"checkpoint_interval": 0.05, "snapshot_interval": 0.05})
    sim = Simulation(scene, out_dir=tmp_path)
    sim.run(end=0.1, progress=False)
    return sim


@pytest.mark.parametrize("poison", ["nan", "escape"])
def test_watchdog_names_the_particle_and_keeps_the_last_checkpoint(tmp_path, poison):
    sim = small_run(tmp_path)
    gid = 17
    v = sim.gathered("velocity")["velocity"][gid]
    ids = sim.contacts()["ids"]
    partners = set(ids[(ids == gid).any(axis=1)].ravel().tolist())
    if poison == "nan":  # the forces recomputed after the edit carry the NaN to its partners
        sim.set_particles(gid, velocity=(v[0], np.nan))
    else:  # the outermost disk thrown out through the outer wall, faster than any contact
        # can stop it (moved onto another disk instead, it trips the overlap guard first)
        s = sim.gathered("position", "kind")
        free = np.flatnonzero(s["kind"] == 0)
        gid = int(free[np.argmax(np.hypot(*s["position"][free].T))])
        x = s["position"][gid]
        sim.set_particles(gid, velocity=300.0 * x / np.hypot(*x))
        partners = {gid}
    with pytest.raises(SimulationError) as err:
        sim.run(end=0.2, progress=False)
    msg = str(err.value)
    gid = int(msg.split("particle id ")[1].split()[0])
    assert gid in partners | {17}, (gid, partners)  # 17: the poisoned one
    assert f"particle id {gid} became invalid at t = " in msg and "position (" in msg
    assert "the last checkpoint is kept" in msg
    t_bad = float(msg.split("invalid at t = ")[1].split(" s")[0])
    assert 0.1 < t_bad < 0.1 + 0.01  # caught within the first steps
    assert f"run stopped: particle id {gid}" in (tmp_path / "log.txt").read_text()
    # the checkpoint on disk is the last one before the failure, and a valid state
    with h5py.File(tmp_path / "checkpoint.h5") as h5:
        assert 0.099 < h5.attrs["time"] < t_bad
        x = h5["x"][()]
        assert np.all(np.isfinite(x)) and np.all(np.isfinite(h5["v"][()]))
        assert np.hypot(*x[h5["kind"][()] == 0].T).max() < 0.09


def test_watchdog_on_two_ranks_stops_every_rank(tmp_path):
    scene = tmp_path / "w.toml"
    write_scene(couette_scene(counts=(260, 40), geometry={**CELL, "outer_start_radius": 0.11,
                                                          "compression_time": 0.1},
                              output={"checkpoint_interval": 0.05}, name="w"), scene)
    proc = run_mpi([str(MPI_DIR / "watchdog.py"), str(scene), str(tmp_path / "out")], 2,
                   timeout=600, check=False, module=False)
    assert proc.returncode == 3, proc.stderr
    assert "run stopped: particle id" in proc.stderr and "position (nan, " in proc.stderr
    assert "at the last neighbour-list build it was at (" in proc.stderr
    with h5py.File(tmp_path / "out" / "checkpoint.h5") as h5:
        assert h5.attrs["time"] == pytest.approx(0.05, abs=1e-4)
        assert h5.attrs["ranks"] == 2 and np.all(np.isfinite(h5["v"][()]))

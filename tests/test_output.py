"""Files for ParaView/pyvista/meshio: every written file is read back with an independent reader
and compared with the simulation's in-memory state."""

import ctypes.util
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import meshio
import numpy as np
import pytest
from helpers import couette_scene, kill_when

import pardem
from averaging.mesh import SEGMENTS
from pardem.cli import main
from averaging.io import read_rings
from pardem.input.scene_file import write_scene
from pardem.simulation import Simulation

ROOT = Path(__file__).parent.parent
SMALL_CELL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
              "compression_time": 0.1, "omega_inner": 3.0}


def small_cell(**output):
    return couette_scene(counts=(260, 40), geometry=SMALL_CELL,
                         output={"snapshot_interval": 0.05, **output},
                         averaging={"start": 0.1, "end": 0.2, "sample_interval": 0.05},
                         time={"end": 0.22})


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A small cell run to 0.2 s; returns the folder and the final in-memory state."""
    out = tmp_path_factory.mktemp("run")
    sim = Simulation(small_cell(), out_dir=out)
    sim.run(progress=False)
    return out, sim.particle_arrays(), sim.contacts(), sim.rings.fields()


def xdmf_grids(path: Path) -> list[ET.Element]:
    root = ET.parse(path).getroot()
    return root.find("Domain").find("Grid").findall("Grid")


def test_hdf5_snapshot_holds_the_in_memory_state(run):
    out, state, contacts, _ = run
    last_file = sorted((out / "snapshots").iterdir())[-1]
    with h5py.File(last_file) as last:
        np.testing.assert_array_equal(last["id"][()], state["id"])
        np.testing.assert_array_equal(last["position"][:, :2], state["position"])
        np.testing.assert_array_equal(last["position"][:, 2], 0.0)
        np.testing.assert_array_equal(last["force"][:, :2], state["force"])
        np.testing.assert_array_equal(last["kind"][()], state["kind"])
        np.testing.assert_array_equal(last["rank"][()], np.where(state["kind"] == 0, 0, -1))
        c = last["contacts"]
        np.testing.assert_array_equal(c["ids"][()], contacts["ids"])
        # the line cells join exactly the two particles of each contact
        np.testing.assert_array_equal(last["id"][()][c["cells"][()]], contacts["ids"])
        np.testing.assert_array_equal(c["normal_force"][()], contacts["normal_force"])
    # t = 0, 0.05, ..., 0.2 and the final state at 0.22
    assert len(list((out / "snapshots").iterdir())) == 6


def test_output_lands_at_the_exact_times_the_scene_names(run):
    """Snapshots every 0.05 s, ring samples every 0.05 s from 0.1 s, the end at 0.22 s: each
    stored time is the double nearest to that decimal (0.15, not 0.1499999...), in the
    snapshot files, the XDMF index, rings.h5 and the checkpoint."""
    out = run[0]
    want = [0.0, 0.05, 0.1, 0.15, 0.2, 0.22]
    assert [s["time"] for s in pardem.read_snapshots(out)] == want
    index = [float(g.find("Time").get("Value")) for g in xdmf_grids(out / "particles.xdmf")]
    assert index == want
    assert read_rings(out)["times"].tolist() == [0.1, 0.15, 0.2]
    with h5py.File(out / "checkpoint.h5") as h5:
        assert h5.attrs["time"] == 0.22


def test_particles_xdmf_reads_back_in_pyvista_and_meshio(run):
    pv = pytest.importorskip("pyvista")
    out, state, _, _ = run
    grids = xdmf_grids(out / "particles.xdmf")
    assert len(grids) == 6
    # ParaView's Xdmf3 reader shows no cells without an explicit connectivity item
    topo = grids[-1].find("Topology")
    assert topo.get("TopologyType") == "Polyvertex" and topo.find("DataItem") is not None
    reader = pv.get_reader(str(out / "particles.xdmf"))
    assert reader.number_time_points == 6
    reader.set_active_time_value(reader.time_values[-1])
    mesh = reader.read()
    assert mesh.n_points == mesh.n_cells == state["id"].size
    np.testing.assert_array_equal(mesh.points[:, :2], state["position"])
    np.testing.assert_array_equal(mesh.point_data["id"], state["id"])
    np.testing.assert_array_equal(mesh.point_data["velocity"][:, :2], state["velocity"])
    np.testing.assert_array_equal(mesh.point_data["coordination"], state["coordination"])
    with meshio.xdmf.TimeSeriesReader(out / "particles.xdmf") as r:
        points, cells = r.read_points_cells()
        assert cells[0].type == "vertex" and len(cells[0].data) == state["id"].size
        t, point_data, _ = r.read_data(r.num_steps - 1)
    assert t == pytest.approx(0.22, abs=1e-4)
    np.testing.assert_array_equal(point_data["position"][:, :2], state["position"])
    np.testing.assert_array_equal(point_data["torque"], state["torque"])


def test_contacts_xdmf_lines_join_the_touching_centres(run):
    pv = pytest.importorskip("pyvista")
    out, state, contacts, _ = run
    reader = pv.get_reader(str(out / "contacts.xdmf"))
    reader.set_active_time_value(reader.time_values[-1])
    lines = reader.read()
    m = contacts["ids"].shape[0]
    assert lines.n_cells == m > 100
    ends = lines.cell_connectivity.reshape(m, 2)
    row = np.searchsorted(state["id"], contacts["ids"])
    np.testing.assert_array_equal(lines.points[ends][:, :, :2], state["position"][row])
    np.testing.assert_array_equal(lines.cell_data["normal_force"], contacts["normal_force"])
    np.testing.assert_array_equal(lines.cell_data["tangential_force"][:, :2],
                                  contacts["tangential_force"])
    sliding = lines.cell_data["sliding"]
    assert set(np.unique(sliding)) <= {0, 1}
    mu = pardem.load_scene(out / "scene.toml").contact.mu
    ratio = np.hypot(*contacts["tangential_force"].T) / (mu * np.abs(contacts["normal_force"]))
    # the applied forces: a sliding contact sits on the Coulomb limit to rounding, no contact
    # exceeds it, and some stick just below it
    assert sliding.sum() > 10 and np.all(np.abs(ratio[sliding == 1] - 1) < 1e-12)
    assert np.all(ratio[sliding == 0] < 1)


def test_rings_vtu_carries_the_ring_fields(run):
    pv = pytest.importorskip("pyvista")
    out, _, _, fields = run
    rings = read_rings(out)
    mesh = pv.read(out / "rings.vtu")
    n = rings["nu"].size
    assert mesh.n_cells == n * SEGMENTS
    ring = mesh.cell_data["ring"]
    for key in ("nu", "v_phi", "tr_sigma", "mu_c", "C", "nu_err"):
        np.testing.assert_array_equal(mesh.cell_data[key], rings[key][ring], key)
        np.testing.assert_allclose(rings[key], fields[key], rtol=0, atol=0, equal_nan=True)
    sigma = mesh.cell_data["sigma"].reshape(-1, 3, 3)
    np.testing.assert_array_equal(sigma[:, 0, 1], rings["sigma_rphi"][ring])
    np.testing.assert_array_equal(sigma[:, 2], 0.0)
    # each cell lies in its ring: the cell centres' radii are within the ring's edges
    centre = np.hypot(*mesh.cell_centers().points[:, :2].T)
    dr = rings["r"][1] - rings["r"][0]
    assert np.all(np.abs(centre - rings["r"][ring]) < 0.5 * dr)
    # the Cartesian velocity is v_phi e_phi + v_r e_r at the cell centre
    phi = np.arctan2(*mesh.cell_centers().points[:, 1::-1].T)
    v = mesh.cell_data["velocity"]
    np.testing.assert_allclose(-v[:, 0] * np.sin(phi) + v[:, 1] * np.cos(phi),
                               rings["v_phi"][ring], atol=1e-12, equal_nan=True)
    assert meshio.read(out / "rings.vtu").cells[0].type == "quad"


def test_killed_run_leaves_every_finished_snapshot_readable(tmp_path):
    """kill -9 while the run writes snapshots; files stay readable and list only whole
    snapshots, and the run continues from the checkpoint."""
    write_scene(couette_scene(counts=(260, 40), geometry=SMALL_CELL,
                              output={"snapshot_interval": 0.01, "checkpoint_interval": 0.05},
                              time={"end": 5.0}), tmp_path / "s.toml")
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "pardem.cli", "run", str(tmp_path / "s.toml"),
                             "--out", str(out), "--quiet"], stderr=subprocess.DEVNULL)
    _, exited = kill_when(proc, lambda: (out / "particles.xdmf").exists()
                          and len(xdmf_grids(out / "particles.xdmf")) >= 12, poll=0.05)
    assert exited is None, f"the run to be killed exited early ({exited})"
    grids = xdmf_grids(out / "particles.xdmf")
    snaps = list(pardem.read_snapshots(out))
    assert len(snaps) >= len(grids) >= 12
    for grid in grids:  # every dataset the index names exists with the stated shape
        for item in grid.iter("DataItem"):
            name, path = item.text.split(":")
            with h5py.File(out / name) as h5:
                assert h5[path].shape == tuple(int(d) for d in item.get("Dimensions").split())
    pv = pytest.importorskip("pyvista")
    reader = pv.get_reader(str(out / "particles.xdmf"))
    reader.set_active_time_value(reader.time_values[-1])
    assert reader.read().n_points == snaps[0]["id"].size
    # the checkpoint is whole too: the run continues
    with h5py.File(out / "checkpoint.h5") as h5:
        t_ckpt = float(h5.attrs["time"])
    done = subprocess.run([sys.executable, "-m", "pardem.cli", "run", str(tmp_path / "s.toml"),
                           "--out", str(out), "--restart", str(out / "checkpoint.h5"),
                           "--end", str(t_ckpt + 0.02), "--quiet"], capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    # snapshots past the checkpoint were rewritten by the continued run; the index and the
    # file agree again, snapshot for snapshot
    grids = xdmf_grids(out / "particles.xdmf")
    times = [s["time"] for s in pardem.read_snapshots(out)]
    assert [float(g.find("Time").get("Value")) for g in grids] == times
    assert times[-1] == pytest.approx(t_ckpt + 0.02, abs=1e-4)


def test_pardem_render_writes_non_trivial_pictures(run, tmp_path):
    pytest.importorskip("pyvista")
    if not any(ctypes.util.find_library(name) for name in ("EGL", "OSMesa")):
        pytest.skip("off-screen rendering needs Mesa's EGL (apt-get install libegl1 "
                    "libegl-mesa0 libgl1-mesa-dri) or OSMesa (libosmesa6); .ci/run installs it")
    out = run[0]
    done = subprocess.run([sys.executable, "-m", "pardem.cli", "render", str(out),
                           "--size", "400", "--fields", "nu", "tr_sigma", "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    names = sorted(p.name for p in tmp_path.glob("*.png"))
    assert names == ["rings_nu.png", "rings_tr_sigma.png", "snapshot_000005_forces.png",
                     "snapshot_000005_speed.png"]
    from PIL import Image

    for name in names:
        img = np.asarray(Image.open(tmp_path / name).convert("RGB"))
        assert img.shape == (400, 500, 3), name
        colours = np.unique(img.reshape(-1, 3), axis=0)
        assert len(colours) > 20, f"{name}: only {len(colours)} colours"
        white = np.all(img == 255, axis=-1).mean()
        assert 0.2 < white < 0.95, f"{name}: {white:.0%} white"


def test_index_appended_per_snapshot_equals_one_rebuilt_from_the_file(run, tmp_path):
    from pardem.output import xdmf

    out = run[0]
    (tmp_path / "snapshots").symlink_to(out / "snapshots")
    xdmf.rebuild(tmp_path)
    for name in ("particles.xdmf", "contacts.xdmf"):
        assert (tmp_path / name).read_text() == (out / name).read_text()


def test_paraview_itself_opens_the_run(run):
    """With Debian's ParaView installed (pvbatch; skipped otherwise): its default readers see
    every snapshot, one cell per particle (the Xdmf3 Polyvertex trap), one line per contact."""
    import json
    import shutil

    pvbatch = shutil.which("pvbatch")
    if pvbatch is None:
        pytest.skip("ParaView (pvbatch) is not installed")
    out, state, contacts, fields = run
    cmd = [pvbatch, str(ROOT / "tests" / "paraview" / "check_run.py"), str(out)]
    if not os.environ.get("DISPLAY") and shutil.which("xvfb-run"):
        cmd = ["xvfb-run", "-a"] + cmd  # Debian's pvbatch has no off-screen backend
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300,
                          env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    assert done.returncode == 0, done.stderr
    seen = {d["file"]: d for d in map(json.loads, done.stdout.splitlines()[-3:])}
    n = state["id"].size
    p = seen["particles.xdmf"]
    assert (p["times"], p["points"], p["cells"]) == (6, n, n)
    assert {"id", "radius", "velocity", "force", "rank", "coordination"} <= set(p["point_arrays"])
    c = seen["contacts.xdmf"]
    assert (c["points"], c["cells"]) == (n, contacts["ids"].shape[0])
    assert {"normal_force", "tangential_force", "sliding"} <= set(c["cell_arrays"])
    r = seen["rings.vtu"]
    assert r["cells"] == fields["nu"].size * SEGMENTS
    assert {"nu", "mu_c", "sigma"} <= set(r["cell_arrays"])


def test_snapshots_without_contacts_are_left_out_of_the_contact_index(run):
    """XDMF readers fail on a grid of zero cells: the dilute start (t = 0, no contacts) is in
    particles.xdmf but not in contacts.xdmf, and every time pyvista offers reads as lines."""
    pv = pytest.importorskip("pyvista")
    out = run[0]
    snaps = list(pardem.read_snapshots(out))
    empty = {i for i, s in enumerate(snaps) if s["contacts"]["ids"].shape[0] == 0}
    assert 0 in empty and len(empty) < len(snaps)
    names = {int(g.get("Name").rsplit("_", 1)[1]) for g in xdmf_grids(out / "contacts.xdmf")}
    assert names == set(range(len(snaps))) - empty
    reader = pv.get_reader(str(out / "contacts.xdmf"))
    for t in reader.time_values:
        reader.set_active_time_value(t)
        assert reader.read().n_cells > 0


def test_pardem_render_of_a_free_scene(tmp_path):
    """A free scene has no wall disks and no rings: disks and force chains only."""
    pytest.importorskip("pyvista")
    if not any(ctypes.util.find_library(name) for name in ("EGL", "OSMesa")):
        pytest.skip("off-screen rendering needs Mesa's EGL or OSMesa")
    scene = ROOT / "examples" / "free_collision.toml"
    assert main(["run", str(scene), "--out", str(tmp_path / "run"), "--end", "0.027",
                 "--quiet"]) == 0
    done = subprocess.run([sys.executable, "-m", "pardem.cli", "render", str(tmp_path / "run"),
                           "--size", "300", "--out", str(tmp_path / "pics")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in (tmp_path / "pics").glob("*.png"))[0].endswith("_forces.png")


@pytest.mark.parametrize("end_step, last", [(401, 400), (410, 410)])
def test_one_end_snapshot(tmp_path, end_step, last):
    """Snapshots every 200 steps: a run ending one step after the grid's last snapshot does
    not store a second one a step later (the checkpoint holds the end state); one ending 10
    steps (5 % of the interval) after it does."""
    import dataclasses

    scene = pardem.load_scene(ROOT / "tests" / "scenes" / "two_small.toml")
    dt = Simulation(scene).dt
    scene = dataclasses.replace(scene, output=dataclasses.replace(
        scene.output, snapshot_interval=200 * dt, checkpoint_interval=1.0))
    sim = Simulation(scene, out_dir=tmp_path)
    sim.run(end=end_step * dt, progress=False)
    steps = [s["step"] for s in pardem.read_snapshots(tmp_path)]
    assert steps == [0, 200, 400] + ([last] if last != 400 else [])
    with h5py.File(tmp_path / "checkpoint.h5") as h5:
        assert h5.attrs["step"] == end_step

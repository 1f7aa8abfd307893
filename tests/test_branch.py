"""Branching runs (``--from``): one packing prepared (compressed and sheared), then runs with
other material or drive from its state; what carries over, what is reset and said, what is
refused. (The 2-rank branch: test_mpi.py.)"""

import shutil
from fractions import Fraction

import numpy as np
import pytest
from helpers import K_N, M_SMALL, analytic_collision, couette_scene
from test_restart import FIELDS

from pardem.cli import main
from pardem.input.scene import SceneError
from pardem.input.scene_file import write_scene
from pardem.simulation import Simulation

PREPARED = 0.15  # s: compressed in 0.1 s, then sheared
SHEARED = {"start": PREPARED, "end": 0.45, "sample_interval": 0.005}


def cell(contact=None, effects=None, averaging=None, counts=(260, 40), time=None, **geometry):
    # test_restart's small cell: dense, sheared, rough rings (wall disks), so that springs,
    # ring contacts and the ring angle all matter
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 1.0, **geometry}
    return couette_scene(counts=counts, geometry=g, contact=contact, effects=effects,
                         averaging=averaging, time=time, output={"checkpoint_interval": 0.05,
                                                      "snapshot_interval": 0.05})


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    """The prepared run's folder (its checkpoint at PREPARED) and the state the same run
    reaches at 0.25 s without a stop."""
    root = tmp_path_factory.mktemp("branch")
    sim = Simulation(cell(), out_dir=root / "run")
    sim.run(end=PREPARED, progress=False)
    (root / "prepared").mkdir()
    shutil.copy(root / "run" / "checkpoint.h5", root / "prepared" / "checkpoint.h5")
    sim.run(end=0.25, progress=False)
    return root / "prepared", sim.checkpoint_state()[0]


def log_of(folder) -> str:
    return (folder / "log.txt").read_text()


def test_a_branch_with_the_same_physics_continues_bit_for_bit(prepared, tmp_path):
    folder, uninterrupted = prepared
    sim = Simulation(cell(averaging=SHEARED), out_dir=tmp_path, branch=folder)  # other output
    assert sim.time == PREPARED
    sim.run(end=0.25, progress=False)
    got = sim.checkpoint_state()[0]
    assert np.abs(got["pair_hist"]).max() > 0 and got["pair_hist"].shape[0] > 50
    for name in FIELDS:
        np.testing.assert_array_equal(got[name], uninterrupted[name], name)


def test_two_mu_branches_start_alike_and_the_higher_mu_needs_more_torque(prepared, tmp_path):
    """Coulomb friction carries shear stress: at mu = 0.8 the inner ring needs more torque
    than at mu = 0.05 (measured ~4x over 0.3 s; half of that asked)."""
    folder, _ = prepared
    torques, starts, ends = {}, {}, {}
    for mu in (0.05, 0.8):
        sim = Simulation(cell({"mu": mu}, averaging=SHEARED), out_dir=tmp_path / str(mu),
                         branch=folder)
        assert f"changed: [contact] mu: 0.44 -> {mu}" in log_of(tmp_path / str(mu))
        starts[mu] = sim.checkpoint_state()[0]
        sim.run(end=SHEARED["end"], progress=False)
        torques[mu] = abs(np.mean(sim.rings.torques))
        ends[mu] = sim.particle_arrays()["position"]
    for name in ("x", "v", "omega", "theta"):
        np.testing.assert_array_equal(starts[0.05][name], starts[0.8][name], name)
    assert np.abs(ends[0.8] - ends[0.05]).max() > 1e-4  # m: then they part
    assert torques[0.8] > 2.0 * torques[0.05] > 0


def test_a_branch_starts_from_the_prepared_springs_without_moving_them(prepared, tmp_path):
    """The new law's first forces are computed at the prepared state without a step: the
    springs stay the checkpoint's (with a higher mu none is capped; a spring moved on by
    v_t dt would differ by ~1e-7 m, a few per cent)."""
    from pardem.output.checkpoint import open_checkpoint

    folder, _ = prepared
    sim = Simulation(cell({"mu": 0.8}), branch=folder)
    got = sim.checkpoint_state()[0]
    with open_checkpoint(folder) as (arrays, attrs):
        want = {k: arrays[k][()] for k in ("pair_lo", "pair_hi", "pair_hist", "hist_wall", "x")}
        step = int(attrs["step"])
    assert sim.step == step
    np.testing.assert_array_equal(got["x"], want["x"])
    for k in ("pair_lo", "pair_hi"):
        np.testing.assert_array_equal(got[k], want[k], k)
    spring = slice(0, 2)  # the linear law keeps no normal history: the spring comes first
    scale = np.abs(want["pair_hist"][:, spring]).max()
    np.testing.assert_allclose(got["pair_hist"][:, spring], want["pair_hist"][:, spring],
                               rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(got["hist_wall"][:, spring], want["hist_wall"][:, spring],
                               rtol=0, atol=1e-9 * scale)


def test_friction_off_drops_the_springs_and_back_on_starts_from_zero(prepared, tmp_path):
    folder, _ = prepared
    off = Simulation(cell(effects={"tangential_friction": False}), out_dir=tmp_path / "off",
                     branch=folder)
    assert "tangential springs dropped: tangential friction is off in this branch" in log_of(
        tmp_path / "off")
    off.run(end=0.2, progress=False)
    on = Simulation(cell(), out_dir=tmp_path / "on", branch=tmp_path / "off")
    assert ("tangential springs reset: tangential friction is off in the prepared run"
            in log_of(tmp_path / "on"))
    state = on.checkpoint_state()[0]
    assert on.time == 0.2 and on.contacts()["ids"].shape[0] > 50  # touching, yet
    assert state["pair_hist"].size == 0 and not np.any(state["hist_wall"])  # no spring
    on.advance_steps(20)
    assert np.abs(on.checkpoint_state()[0]["pair_hist"]).max() > 0  # the law loads them


def test_a_branch_with_another_omega_keeps_the_ring_angle(prepared, tmp_path):
    """The inner ring's wall disks stay where the prepared run left them, and turn on at the
    new speed: omega_inner 1 -> -2 rad/s."""
    folder, _ = prepared
    sim = Simulation(cell(omega_inner=-2.0), out_dir=tmp_path, branch=folder)
    before = sim.particle_arrays()
    from pardem.output.checkpoint import open_checkpoint

    with open_checkpoint(folder) as (arrays, attrs):
        x = arrays["x"][()]
        angle = float(attrs["ring_angle"])
    inner = before["kind"] == 1
    np.testing.assert_allclose(before["position"][inner], x[inner], rtol=0, atol=1e-15)
    np.testing.assert_allclose(before["theta"][inner], angle, rtol=1e-12)
    np.testing.assert_allclose(before["omega"][inner], -2.0)
    sim.advance_steps(100)
    after = sim.particle_arrays()
    turned = np.arctan2(after["position"][inner, 1], after["position"][inner, 0]) - np.arctan2(
        x[inner, 1], x[inner, 0])
    np.testing.assert_allclose(np.angle(np.exp(1j * turned)), -2.0 * 100 * sim.dt, rtol=1e-9)


def test_a_restart_of_a_branch_with_another_omega_continues_it_bit_for_bit(prepared,
                                                                          tmp_path):
    """The ring's phase travels with the branch's checkpoints."""
    folder, _ = prepared
    sim = Simulation(cell(omega_inner=-2.0), out_dir=tmp_path / "b", branch=folder)
    sim.run(end=0.2, progress=False)
    sim.write_checkpoint(tmp_path / "mid.h5")
    sim.run(end=0.25, progress=False)
    again = Simulation(cell(omega_inner=-2.0), out_dir=tmp_path / "again",
                       restart=tmp_path / "mid.h5")
    again.run(end=0.25, progress=False)
    a, b = again.checkpoint_state(), sim.checkpoint_state()
    assert a[1]["ring_phase"] == b[1]["ring_phase"] != 0.0
    for name in FIELDS:
        np.testing.assert_array_equal(a[0][name], b[0][name], name)


def test_a_stiffer_branch_keeps_the_time_with_its_own_step(prepared, tmp_path):
    """k_n x 2: dt follows the damped contact time of the lightest pair (t_c / 50, shortened
    by up to 1 % to divide 10 ms); the prepared time 0.15 s is a whole number of the new
    steps. From a checkpoint one old step later it is not: the branch starts at the nearest
    new step and says so."""
    folder, _ = prepared
    old = Simulation(cell(), restart=folder)
    stiff = Simulation(cell({"k_n": 2 * K_N}), out_dir=tmp_path / "a", branch=folder)
    assert stiff.time == PREPARED and stiff.step * stiff.step_length == Fraction(3, 20)
    ratio = analytic_collision(M_SMALL / 2, 2 * K_N)[0] / analytic_collision(M_SMALL / 2)[0]
    assert 0.99 * ratio <= stiff.dt / old.dt <= ratio / 0.99
    assert "[contact] k_n: 352.1 -> 704.2" in log_of(tmp_path / "a")
    old.advance_steps(1)
    old.write_checkpoint(tmp_path / "odd.h5")
    later = Simulation(cell({"k_n": 2 * K_N}), out_dir=tmp_path / "b",
                       branch=tmp_path / "odd.h5")
    assert abs(later.time - old.time) <= 0.5 * later.dt and later.time != old.time
    assert "is not a whole number of steps of the new dt" in log_of(tmp_path / "b")
    later.advance_steps(200)
    assert later.max_overlap() < 0.1


@pytest.mark.parametrize("change, message", [
    (dict(counts=(250, 40)), "300 free particles in the prepared run, 290 here"),
    (dict(counts=(250, 50)), r"\[\[species\]\] #0 \(small\) count is 260 in the prepared run, "
                             "250 here"),
    (dict(inner_radius=0.051), r"\[geometry\] inner_radius is 0.05 in the prepared run, "
                               "0.051 here"),
    (dict(outer_wall_count=0), r"\[geometry\] outer_wall_count is 'auto' in the prepared "
                               "run, 0 here"),
])
def test_a_branch_that_changes_the_particles_or_the_geometry_is_refused(prepared, change,
                                                                        message):
    folder, _ = prepared
    with pytest.raises(SceneError, match=r"--from .*: " + message):
        Simulation(cell(**change), branch=folder)


def test_a_branch_that_ends_before_the_prepared_time_is_refused(prepared):
    folder, _ = prepared
    with pytest.raises(SceneError, match=r"\[time\] end = 0.1 s does not lie after the "
                                         r"prepared state's time 0.15 s"):
        Simulation(cell(time={"end": 0.1}), branch=folder)


def test_the_command_line_refuses_a_folder_without_a_checkpoint(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    write_scene(cell(), scene)
    (tmp_path / "empty").mkdir()
    status = main(["run", str(scene), "--from", str(tmp_path / "empty"), "--out",
                   str(tmp_path / "out"), "--quiet"])
    assert status == 2
    assert f"--from {tmp_path / 'empty'}: a folder without checkpoint.h5" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # one way to start: argparse says so
        main(["run", str(scene), "--from", "a", "--restart", "b"])


def test_the_command_line_branches_with_end(prepared, tmp_path, capsys):
    folder, _ = prepared
    scene = tmp_path / "s.toml"
    write_scene(cell({"mu": 0.3}), scene)
    assert main(["run", str(scene), "--from", str(folder), "--out", str(tmp_path / "b"),
                 "--end", "0.16", "--quiet"]) == 0
    assert "changed: [contact] mu: 0.44 -> 0.3" in log_of(tmp_path / "b")
    assert "changed: [contact] mu: 0.44 -> 0.3" in capsys.readouterr().err
    assert main(["run", str(scene), "--from", str(folder), "--out", str(tmp_path / "c"),
                 "--end", "0.1", "--quiet"]) == 2
    assert "does not lie after the prepared state's time 0.15 s" in capsys.readouterr().err


def test_a_branch_that_averages_from_before_the_prepared_time_is_refused(prepared):
    folder, _ = prepared
    early = {**SHEARED, "start": 0.1}
    with pytest.raises(SceneError, match=r"\[averaging\] start = 0.1 s lies before the prepared "
                                         r"state's time 0.15 s"):
        Simulation(cell(averaging=early), branch=folder)

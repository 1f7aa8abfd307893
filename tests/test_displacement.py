"""The paper's contact displacement eta (eq. 1.3): the total tangential displacement of a
contact, integral of v_t dt over its life, kept beside the Cundall-Strack spring xi.

eta must (1) equal the integral of the relative tangential velocity (analytic, for disks that
slide past each other at constant velocity), (2) equal the spring bit for bit while no
contact has slid, (3) never change the dynamics, and (4) make the couple stress and the
curvature differ where contacts slide: with the spring (the default Delta), M = (k_t / pi h)
kappa . F holds identically, ring by ring (f_t = -k_t xi, Delta_t = -xi), so mu_c restates
the fabric; (5) a contact that slides steadily keeps its spring at the Coulomb cap while eta
grows, and the ring sums of both choices of Delta agree with a computation by hand.
"""

import dataclasses
import math

import numpy as np
import pytest
from helpers import D_SMALL, K_N, K_T, MU, couette_scene, free_scene

from averaging.fields import COL
from averaging.sample import sample_simulation
from averaging.timeavg import RingAverager
from pardem.output.snapshots import read_snapshots
from pardem.input.scene import AveragingCfg
from pardem.simulation import Simulation


def _shear_cell(mu=0.44, averaging=None, output=None, end=0.4, omega=10.0):
    """A small dense cell compressed in 0.1 s and sheared at 10 rad/s: contacts slide."""
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": omega}
    scene = couette_scene(counts=(260, 40), geometry=g, time={"end": end}, output=output,
                          averaging=averaging, name="shear-cell")
    return dataclasses.replace(scene, contact=dataclasses.replace(scene.contact, mu=mu))


def _averager(sim):
    g, c = sim.scene.geometry, sim.scene.contact
    return RingAverager(g.inner_radius, g.outer_radius, D_SMALL / 4, "slice", c.height,
                        8e-3, c.k_n, g.omega_inner)


def _with_displacement(sim, which):
    """The same Simulation object, sampled with another [averaging] displacement."""
    sim.scene = dataclasses.replace(sim.scene, averaging=dataclasses.replace(
        sim.scene.averaging, displacement=which))
    return sim


def _fields_at_end(sim, which):
    avg = _averager(sim)
    avg.add(sample_simulation(_with_displacement(sim, which)), sim.time)
    return avg.fields()


def _sliding_pair(x0, y0, u, end, dt, centre=(0.0, 0.0)):
    """Disk 1 at rest at ``centre``, disk 0 at centre + (x0, y0) moving along x at u; both of
    huge mass, so the contact forces (~0.01 N) hardly change the motion. u and dt are small
    enough for the approach-speed limit (which does not look at the direction): the masses
    make any head-on meeting deep."""
    big = 1e9  # kg
    scene = free_scene([{"x": centre[0] + x0, "y": centre[1] + y0, "vx": u, "diameter": D_SMALL,
                         "mass": big},
                        {"x": centre[0], "y": centre[1], "diameter": D_SMALL, "mass": big}],
                       effects={"tangential_friction": True}, time={"dt": dt, "end": end})
    return dataclasses.replace(scene, output=dataclasses.replace(
        scene.output, snapshot_interval=end / 3, checkpoint_interval=end))


def test_eta_is_the_integral_of_the_tangential_velocity(tmp_path):
    """Two disks of huge mass slide past each other: disk 1 rests at the origin, disk 0 moves
    along x with its centre at height y0 < a0 + a1, so they overlap all the time. v_ij . t =
    -u y0/|r| with t = z x n, so eta . t = -y0 [asinh(x/y0)] between the first and the last x
    (independent of the code; x from the final state, which the forces shift by ~1e-6 m). The
    spring stays capped at mu f_n / k_t."""
    a = D_SMALL / 2
    y0, x0 = 0.995 * 2 * a, -3e-4
    scene = _sliding_pair(x0, y0, 1e-6, 600.0, 1e-2)
    sim = Simulation(scene, out_dir=tmp_path)  # contacts written: eta tracked
    sim.run(progress=False)
    c = sim.contacts()
    assert c["ids"].tolist() == [[0, 1]]
    n = c["normal"][0]
    t_hat = np.array([-n[1], n[0]])
    pos = sim.particle_arrays()["position"]
    x1 = pos[0, 0] - pos[1, 0]
    expected = -y0 * (math.asinh(x1 / y0) - math.asinh(x0 / y0))
    eta = c["displacement"][0]
    assert abs(eta @ n) < 1e-12  # kept in the tangent plane
    assert eta @ t_hat == pytest.approx(expected, rel=2e-3)
    cap = scene.contact.mu * abs(c["normal_force"][0]) / K_T
    assert np.hypot(*c["spring"][0]) == pytest.approx(cap, rel=1e-6)
    assert abs(expected) > 20 * cap  # the contact slid far beyond its spring
    last = list(read_snapshots(tmp_path))[-1]  # written with the snapshot, like the spring
    assert np.array_equal(last["contacts"]["displacement"], c["displacement"])


def _identity_mismatch(f, h):
    """M - (k_t / pi h) kappa . F, both components, and the rings where M_zr is defined."""
    ok = np.isfinite(f["kappa_zr"]) & (np.abs(f["M_zr"]) > 0)
    k_dot_f = {c: f["kappa_zr"] * f[f"F_r{c}"] + f["kappa_zphi"] * f[f"F_phi{c}"]
               for c in ("r", "phi")}
    return (f["M_zr"] - K_T / (math.pi * h) * k_dot_f["r"],
            f["M_zphi"] - K_T / (math.pi * h) * k_dot_f["phi"], ok)


@pytest.fixture(scope="module")
def sheared_cell():
    """The shear cell after 0.4 s with eta tracked, and contacts at the Coulomb cap."""
    sim = Simulation(_shear_cell(averaging={"start": 0.0, "end": 0.4, "displacement": "eta"}))
    sim.run(progress=False)
    assert sim.contacts()["sliding"].astype(bool).sum() >= 20  # the case needs sliding
    return sim


def test_identity_couple_stress_is_kt_over_pi_h_times_curvature_dot_fabric(sheared_cell):
    """An identity, not a physical result (docs/averaging.md): with Delta = delta n - xi and
    f_t = -k_t xi, l x f = k_t (l x Delta) for every contact, so M = (k_t / pi h) kappa . F
    ring by ring to round-off, in a cell where many contacts slide."""
    h = sheared_cell.scene.contact.height
    m_r, m_phi, ok = _identity_mismatch(_fields_at_end(sheared_cell, "spring"), h)
    f = _fields_at_end(sheared_cell, "spring")
    assert ok.sum() >= 10
    assert np.all(np.abs(m_r[ok]) <= 1e-9 * np.abs(f["M_zr"][ok]) + 1e-300)
    assert np.all(np.abs(m_phi[ok]) <= 1e-9 * np.abs(f["M_zphi"][ok]) + 1e-300)


def test_eta_breaks_the_identity_where_contacts_slide(sheared_cell):
    table = sheared_cell.contacts()
    sliding = table["sliding"].astype(bool)
    eta, xi = table["displacement"], table["spring"]
    # a contact at the cap has slid: eta - xi is its accumulated slip (of either sign)
    slip = np.hypot(*(eta - xi)[sliding].T)
    assert np.all(slip > 0) and np.median(slip / np.hypot(*xi[sliding].T)) > 1
    f = _fields_at_end(sheared_cell, "eta")
    m_r, _, ok = _identity_mismatch(f, sheared_cell.scene.contact.height)
    assert np.sum(np.abs(m_r[ok]) > 0.1 * np.abs(f["M_zr"][ok])) >= 10


def test_without_sliding_eta_is_the_spring_and_the_averages_agree():
    """mu so large that no contact reaches the cap: eta = xi bit for bit, so both choices of
    Delta give identical ring sums."""
    # sheared gently: without sliding, 10 rad/s would press disks beyond the overlap guard
    sim = Simulation(_shear_cell(mu=1e6, averaging={"start": 0.0, "end": 0.4,
                                                    "displacement": "eta"}, end=0.2, omega=2.0))
    sim.run(progress=False)
    table = sim.contacts()
    assert len(table["ids"]) > 300 and not table["sliding"].any()
    assert np.array_equal(table["displacement"], table["spring"])
    ring = sim.ring_contacts()
    assert len(ring["id"]) > 0 and np.array_equal(ring["displacement"], ring["spring"])
    sums = []
    for which in ("spring", "eta"):
        avg = _averager(sim)
        avg.add(sample_simulation(_with_displacement(sim, which)), sim.time)
        sums.append(avg.samples[0])
    assert np.array_equal(sums[0], sums[1])


def test_tracking_eta_leaves_the_trajectory_and_costs_a_history_only_where_read(tmp_path):
    """With eta tracked (contacts written) and without (no output, spring averages) the
    states agree bit for bit; only the history width differs."""
    plain = _shear_cell(averaging={"displacement": "spring"}, end=0.25)
    tracked = _shear_cell(averaging={"displacement": "spring"}, end=0.25)
    runs = []
    for scene, out in ((plain, None), (tracked, tmp_path)):
        sim = Simulation(scene, out_dir=out)
        sim.run(progress=False)
        runs.append(sim)
    assert (runs[0].hist, runs[1].hist) == (2, 4)
    eta_averages = _shear_cell(averaging={"start": 0.0, "displacement": "eta"}, end=0.01)
    assert Simulation(eta_averages).hist == 4
    a, b = (r.checkpoint_state()[0] for r in runs)
    for key in ("x", "v", "omega", "theta", "f", "tau"):
        assert np.array_equal(a[key], b[key]), key
    assert np.array_equal(a["pair_hist"], b["pair_hist"][:, :2])
    assert np.array_equal(a["hist_wall"], b["hist_wall"][:, :2])
    frictionless = _shear_cell(end=0.01)
    frictionless = dataclasses.replace(frictionless, effects=dataclasses.replace(
        frictionless.effects, tangential_friction=False))
    assert Simulation(frictionless).hist == 0


def test_a_checkpoint_without_eta_restarts_with_eta_from_the_spring(tmp_path):
    """A checkpoint written without eta (spring averages, no output) restarts into a run that
    tracks it: eta starts as the spring (exact for contacts that have not slid), and the run
    goes on like the uninterrupted one, without eta."""
    plain = _shear_cell(averaging={"displacement": "spring"}, end=0.3)
    ref = Simulation(plain)
    ref.run(end=0.15, progress=False)
    ref.write_checkpoint(tmp_path / "c.h5")
    ref.run(end=0.3, progress=False)
    again = Simulation(_shear_cell(averaging={"displacement": "eta"}, end=0.3),
                       restart=tmp_path / "c.h5")
    assert again.hist == 4
    c = again.contacts()
    assert len(c["ids"]) > 100 and np.array_equal(c["displacement"], c["spring"])
    again.run(end=0.3, progress=False)
    a, b = again.checkpoint_state()[0], ref.checkpoint_state()[0]
    for key in ("x", "v", "omega", "f", "tau"):
        assert np.array_equal(a[key], b[key]), key
    assert np.array_equal(a["pair_hist"][:, :2], b["pair_hist"])


def _hand_sums(x, n, delta, a, tang):
    """-Sum_p Delta_p (x) l_p and -Sum_p (l_p x Delta_p) l_p in each particle's polar frame,
    Delta = delta n - t, l = -(a - delta/2) n: the totals over the rings of the deform_* and
    curv_* sums (every particle's weights add up to 1)."""
    deform, curv = np.zeros(4), np.zeros(2)
    for xp, np_, tp in zip(x, n, tang):
        er = xp / np.hypot(*xp)
        frame = np.array([er, [-er[1], er[0]]])  # rows e_r, e_phi
        d = frame @ (delta * np_ - tp)
        lv = frame @ (-(a - delta / 2) * np_)
        deform -= np.outer(d, lv).ravel()
        curv -= (lv[0] * d[1] - lv[1] * d[0]) * lv
    return deform, curv


def test_a_steadily_sliding_contact_keeps_the_spring_at_the_cap_while_eta_grows(tmp_path):
    """Disk 0 dragged at constant u over disk 1 at a fixed normal offset (both of huge mass:
    the drag is prescribed; no damping, no rotation). The contact slides all along: the spring
    stays at the Coulomb cap mu f_n / k_t (f_n = k_n delta from the geometry) and points along
    the sliding direction, while eta grows as the integral of v_t. The contact's ring sums of
    Delta (x) l and (l x Delta) l, computed here by hand from the geometry, agree with the
    code's for Delta with the spring and with eta."""
    a, u = D_SMALL / 2, 1e-6
    centre = np.array([0.0, 0.2])  # off the axis, so that the rings and polar frames exist
    y0, x0 = 0.995 * 2 * a, -3e-4
    sim = Simulation(_sliding_pair(x0, y0, u, 600.0, 1e-2, tuple(centre)), out_dir=tmp_path)
    assert sim.hist == 4  # contacts written: eta tracked
    for end in (200.0, 400.0, 600.0):
        sim.run(end=end, progress=False)
        c = sim.contacts()
        xs = sim.particle_arrays()["position"]  # the geometry by hand from the positions
        gap = xs[0] - xs[1]
        n0 = gap / np.hypot(*gap)
        delta = 2 * a - np.hypot(*gap)
        t_hat = np.array([-n0[1], n0[0]])
        cap = MU * K_N * delta / K_T
        slide = np.sign(u * t_hat[0])  # relative velocity (u, 0) along t
        xi0 = cap * slide * t_hat
        eta0 = -y0 * (math.asinh(gap[0] / y0) - math.asinh(x0 / y0)) * t_hat
        assert np.allclose(c["normal"][0], n0, rtol=0, atol=1e-9)
        assert c["overlap"][0] == pytest.approx(delta, rel=1e-6)
        assert np.allclose(c["spring"][0], xi0, rtol=1e-6, atol=0)
        # eta: the integral along the straight path at y0 (the forces shift y by ~1e-6 m)
        assert np.allclose(c["displacement"][0], eta0, rtol=2e-3, atol=0)
        assert np.hypot(*eta0) > 5 * cap  # slid far beyond the spring
        # the sums by hand from the hand spring, and from the contact's eta (checked above)
        for which, t0 in (("spring", xi0), ("eta", c["displacement"][0])):
            sim.scene = dataclasses.replace(sim.scene, averaging=AveragingCfg(
                displacement=which))
            avg = RingAverager(0.18, 0.23, D_SMALL / 8, "slice", sim.scene.contact.height,
                               8e-3, K_N, 0.0)
            avg.add(sample_simulation(sim), sim.time)
            got = avg.samples[0].sum(axis=0)
            deform, curv = _hand_sums(xs, np.array([n0, -n0]), delta, a, np.array([t0, -t0]))
            cols = [COL[f"deform_{k}"] for k in ("rr", "rphi", "phir", "phiphi")]
            assert np.allclose(got[cols], deform, rtol=1e-6, atol=1e-18), which
            assert np.allclose(got[[COL["curv_r"], COL["curv_phi"]]], curv, rtol=1e-6,
                               atol=1e-21), which

"""Hard contact cases stay finite and physical: violent impacts, exactly zero tangential motion,
exactly touching disks, a disk at rest on the bottom."""

import math

import numpy as np
import pytest
from helpers import D_SMALL, GAMMA_N, K_N, M_SMALL, free_scene

from pardem.simulation import Simulation

ALL = {"normal_damping": True, "tangential_friction": True, "rotation": True,
       "bottom_friction": True}


def pair(x2, vx1=0.0, vx2=0.0, vy1=0.0, effects=ALL, y2=0.0):
    return Simulation(free_scene([
        {"x": 0.0, "y": 0.0, "vx": vx1, "vy": vy1, "diameter": D_SMALL, "mass": M_SMALL},
        {"x": x2, "y": y2, "vx": vx2, "diameter": D_SMALL, "mass": M_SMALL}], effects=effects))


def energy(sim):
    """Kinetic (with rotation) + elastic energy (J)."""
    return sim.total_energy()


def analytic_max_overlap(v_rel, m_red):
    """Largest overlap of the damped linear spring hit at v_rel (independent of the code):
    delta(t) = (v/omega) exp(-eta t) sin(omega t), maximal where tan(omega t) = omega/eta."""
    eta = GAMMA_N / (2 * m_red)
    w = math.sqrt(K_N / m_red - eta**2)
    t = math.atan2(w, eta) / w
    return v_rel / w * math.exp(-eta * t) * math.sin(w * t)


@pytest.mark.parametrize("offset", [0.0, 0.3 * D_SMALL])  # head on, and oblique with friction
def test_violent_impact_stays_finite_and_loses_energy(offset):
    """Overlap reaching ~20 % of a diameter at the default dt: no NaN, the largest overlap is the
    analytic one (head on), energy after <= energy before, momentum conserved."""
    v = 2.1  # m/s each, 4.2 m/s closing speed
    sim = pair(D_SMALL * 1.05, vx1=v, vx2=-v, y2=offset)
    e0, p0 = energy(sim), sim.gathered("velocity")["velocity"].sum(axis=0) * M_SMALL
    deepest = 0.0
    for _ in range(400):
        sim.advance_steps(1)
        x = sim.gathered("position")["position"]
        d = np.hypot(*(x[0] - x[1]))
        deepest = max(deepest, D_SMALL - d)
    s = sim.gathered("position", "velocity")
    assert np.all(np.isfinite(s["position"])) and np.all(np.isfinite(s["velocity"]))
    assert d > D_SMALL  # separated again
    e1 = energy(sim)
    assert e1 <= e0
    np.testing.assert_allclose(s["velocity"].sum(axis=0) * M_SMALL, p0, atol=1e-15)
    if offset == 0.0:
        expected = analytic_max_overlap(2 * v, M_SMALL / 2)
        assert expected / D_SMALL > 0.19
        assert deepest == pytest.approx(expected, rel=0.02)


@pytest.mark.parametrize("mu", [0.44, 0.0])
def test_zero_tangential_velocity_and_zero_spring(mu):
    """A head-on collision with friction and rotation on, also with mu = 0 (then the Coulomb
    cap sees |f_t| = mu |f_n| = 0: no 0/0). The spring stays at round-off (n = dx/|dx| is -1
    only to an ulp, so ~1e-21 m leaks in along n and is projected out again), and everything
    transverse stays exactly zero."""
    sim = Simulation(free_scene([
        {"x": 0.0, "y": 0.0, "vx": 0.1, "diameter": D_SMALL, "mass": M_SMALL},
        {"x": D_SMALL * 1.01, "y": 0.0, "diameter": D_SMALL, "mass": M_SMALL}],
        effects=ALL, contact={"mu": mu}))
    for _ in range(300):
        sim.advance_steps(1)
        springs = sim.history_table()[2]  # the live springs: this one pair, while it touches
        assert np.all(np.abs(springs) < 1e-18) and np.all(springs[:, 1] == 0.0)
    s = sim.gathered("position", "velocity", "omega")
    assert np.all(s["omega"] == 0.0) and np.all(s["position"][:, 1] == 0.0)
    assert np.all(s["velocity"][:, 1] == 0.0) and np.all(np.isfinite(s["velocity"]))
    assert s["velocity"][1, 0] > 0.0  # the collision happened


def test_disks_touching_at_exactly_zero_overlap():
    """Centres exactly a_i + a_j apart (delta == 0.0 in floating point): at rest nothing moves
    and no force appears; approaching, the collision is an ordinary one."""
    assert math.sqrt(D_SMALL**2) == D_SMALL  # the set-up really has delta = 0 exactly
    sim = pair(D_SMALL)
    sim.advance_steps(500)
    s = sim.gathered("position", "velocity", "force")
    assert s["position"][1, 0] == D_SMALL and s["position"][0, 0] == 0.0
    assert np.all(s["velocity"] == 0.0) and np.all(s["force"] == 0.0)
    moving = pair(D_SMALL, vx1=0.05)
    moving.advance_steps(300)
    v = moving.gathered("velocity")["velocity"]
    assert v[1, 0] > 0 and np.all(np.isfinite(v))
    assert v[0, 0] < v[1, 0]


def test_disk_at_rest_with_bottom_friction_stays_exactly_at_rest():
    sim = Simulation(free_scene([{"x": 0.0, "y": 0.0, "diameter": D_SMALL, "mass": M_SMALL}],
                                effects=ALL))
    sim.advance_steps(2000)
    s = sim.gathered("position", "velocity")
    assert np.all(s["velocity"][0] == 0.0) and np.all(s["position"][0] == 0.0)


@pytest.mark.parametrize("mu", [0.44, 0.0])
@pytest.mark.parametrize("compiled", [True, False])
def test_contact_law_with_zero_tangential_velocity_and_zero_spring(mu, compiled):
    """The kernel itself, with n exactly along an axis: the tangential velocity and the spring
    are exactly zero, so |f_t|^2 = 0; with mu = 0 also mu |f_n| = 0, where a non-strict Coulomb
    test would compute 0/0. Force, spring and sliding flag come out exact."""
    from pardem.contact.model import ContactOptions, LawParams, contact_law

    law = contact_law if compiled else contact_law.py_func
    prm = LawParams(dt=4.353e-5, k_n=K_N, gamma_n=GAMMA_N, k_t=267.1, mu=mu)
    force, history = law((1.0, 0.0), 1e-4, (-0.1, 0.0), (0.0, 0.0), 0.0, 0.0, 0.0, (0.0, 0.0),
                         prm, ContactOptions())
    assert force.fn == K_N * 1e-4 + GAMMA_N * 0.1
    assert (force.ftx, force.fty, history.xix, history.xiy) == (0.0, 0.0, 0.0, 0.0)
    assert not force.sliding

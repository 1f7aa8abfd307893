"""The optional contact slots against analytic solutions: tangential viscous damping of a
sticking contact, and rolling resistance slowing a rolling disk.

The set-up: one disk rolling along the inside of a smooth fixed ring (no wall disks, no bottom
friction). The ring's normal force is the centripetal one, f_n = m v^2/R_c (R_c: the radius of
the disk's centre), so the contact persists without any other load."""

import math

import numpy as np
import pytest
from helpers import D_SMALL, K_T, M_SMALL, couette_scene

from pardem.input.scene import SceneError
from pardem.simulation import Simulation

A = D_SMALL / 2
R_OUT = 0.09
RING = {"inner_radius": 0.05, "outer_radius": R_OUT, "outer_start_radius": R_OUT,
        "compression_time": 0.0, "omega_inner": 0.0, "inner_wall_count": 0,
        "outer_wall_count": 0}


def rolling_disk(v0: float, spin: float, effects=None, contact=None, per_contact=50,
                 integrator="verlet"):
    """One disk touching the outer ring at the centripetal overlap, moving along it at v0
    (m/s, counter-clockwise) with spin ``spin`` (rad/s); rolling without slip is -v0/a.
    dt = t_c / per_contact."""
    scene = couette_scene(counts=(1, 0), geometry=RING, effects={
        "bottom_friction": False, **(effects or {})}, contact=contact,
        time={"dt_per_contact": per_contact, "integrator": integrator})
    sim = Simulation(scene)
    k_n = scene.contact.k_n
    r_c = R_OUT - A
    r_c += M_SMALL * v0**2 / (r_c * k_n)  # overlap that supplies the centripetal force
    sim.set_particles(0, position=(r_c, 0.0), velocity=(0.0, v0), omega=spin)
    return sim


def orbit(sim):
    """(radius of the centre, v_phi, spin) of the disk."""
    s = sim.gathered("position", "velocity", "omega")
    x, v = s["position"][0], s["velocity"][0]
    r = math.hypot(*x)
    return r, (x[0] * v[1] - x[1] * v[0]) / r, s["omega"][0]


@pytest.mark.parametrize("integrator,per_contact", [("verlet-halfstep", 200), ("verlet", 1600)])
@pytest.mark.parametrize("gamma_t", [0.0, 0.0313])
def test_sticking_contact_oscillates_as_the_damped_tangential_spring(gamma_t, integrator,
                                                                     per_contact):
    """Spin the disk slightly off rolling: the contact point's slip u' = v_phi + a w then obeys
    u'' = -(1/m + a^2/I)(k_t u + gamma_t u'), i.e. a damped oscillator with omega_0^2 = 3 k_t/m
    (I = m a^2/2) and decay rate 3 gamma_t/(2 m), while the Coulomb cap (mu f_n) is far away.
    The measured slip follows u'(t) = u'0 exp(-eta t)(cos w_d t - eta/w_d sin w_d t).

    The steps are fine because of the integrators, not the slot: this mode is stiffer than the
    normal one that the default t_c/50 is set for (omega_0 = 1707 against 1078 rad/s), and the
    default integrator, which increments the spring with the velocity predicted at the end of
    the step, damps it numerically at first order in dt: at t_c/50 the undamped oscillation
    loses ~12 % of its amplitude per period, at t_c/1600 0.5 % (docs/accuracy.md). The
    half-step integrator keeps it (0.4 % in six periods at t_c/50)."""
    v0, kick = 0.2, 0.027  # m/s; rad/s off rolling: slip amplitude a kick ~ 1e-4 m/s
    effects = {"tangential_damping": True} if gamma_t else None
    sim = rolling_disk(v0, -v0 / A + kick, effects, {"gamma_t": gamma_t} if gamma_t else None,
                       per_contact=per_contact, integrator=integrator)
    m, w0 = M_SMALL, math.sqrt(3 * K_T / M_SMALL)
    eta = 3 * gamma_t / (2 * m)
    wd = math.sqrt(w0 * w0 - eta * eta)
    t, slip = [], []
    stride = per_contact // 200  # ~270 samples per period; a gather per step would dominate
    for _ in range(int(6 * 2 * math.pi / wd / sim.dt) // stride):  # six periods
        _, v_phi, spin = orbit(sim)
        t.append(sim.time)
        slip.append(v_phi + A * spin)
        sim.advance_steps(stride)
    t, slip = np.array(t), np.array(slip)
    expected = A * kick * np.exp(-eta * t) * (np.cos(wd * t) - eta / wd * np.sin(wd * t))
    scale = A * kick
    print(f"\n gamma_t = {gamma_t}: omega_d = {wd:.1f} rad/s, decay {eta:.1f} 1/s; largest "
          f"deviation {np.abs(slip - expected).max() / scale:.4f} of the initial slip")
    assert np.abs(slip - expected).max() < 0.03 * scale
    contacts = sim.ring_contacts()
    mobilised = np.hypot(*contacts["tangential_force"][0]) / (0.44 * contacts["normal_force"][0])
    assert mobilised < 0.5  # sticking throughout: the cap was never near


def test_rolling_resistance_slows_a_rolling_disk_as_predicted():
    """At its limit the rolling resistance opposes the rolling with a torque a mu_r f_n. With
    f_n = m v^2/R_c and rolling without slip (the tangential force needed, 2/3 mu_r f_n, is
    far below mu f_n), the energy (3/4) m v^2 falls at the rate mu_r m v^3/R_c:
    v(t) = v0 / (1 + 2 mu_r v0 t / (3 R_c))."""
    v0, mu_r = 0.2, 0.05
    sim = rolling_disk(v0, -v0 / A, {"rolling_resistance": True}, {"k_r": K_T, "mu_r": mu_r})
    for t_end in (1.0, 3.0, 6.0):
        sim.run(end=t_end, progress=False)
        r_c, v_phi, spin = orbit(sim)
        expected = v0 / (1 + 2 * mu_r * v0 * sim.time / (3 * r_c))
        print(f"\n t = {sim.time:.2f} s: v/v0 {v_phi / v0:.5f}, predicted {expected / v0:.5f}; "
              f"slip (v + a w)/v {(v_phi + A * spin) / v_phi:.1e}")
        assert v_phi == pytest.approx(expected, rel=5e-3)
        assert abs(v_phi + A * spin) < 1e-3 * v_phi  # still rolling, not sliding
    assert v_phi < 0.8 * v0  # it did slow down markedly


def test_without_rolling_resistance_the_disk_keeps_rolling():
    sim = rolling_disk(0.2, -0.2 / A)
    sim.run(end=3.0, progress=False)
    assert orbit(sim)[1] == pytest.approx(0.2, rel=1e-4)


@pytest.mark.parametrize("table,keys,message", [
    ("effects", {"tangential_damping": True}, "gamma_t = 0.0: must be > 0"),
    ("contact", {"gamma_t": 0.1}, "tangential_damping is off"),
    ("effects", {"rolling_resistance": True}, "k_r = 0.0: must be > 0"),
    ("contact", {"mu_r": 0.1}, "rolling_resistance is off"),
    ("effects", {"rolling_resistance": True, "rotation": False}, "needs [effects] rotation"),
    ("effects", {"tangential_damping": True, "tangential_friction": False},
     "needs [effects] tangential_friction"),
])
def test_slot_keys_are_checked(table, keys, message):
    with pytest.raises(SceneError, match=message.replace("[", r"\[").replace("]", r"\]")):
        couette_scene(counts=(1, 0), geometry=RING, **{table: keys})

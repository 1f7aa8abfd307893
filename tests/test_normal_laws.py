"""The normal slot's laws against independent computations: head-on collisions of two disks
timed by pardem (testing.measure) and compared with the law's own equation of motion solved
here, plus the scene interface of each law (keys of another law refused)."""

import math
import tomllib

import numpy as np
import pytest

from pardem.contact.model import ContactOptions, contact_law
from pardem.input.scene import SceneError
from pardem.input.scene_file import scene_to_toml
from pardem.input.schema import scene_from_dict
from pardem.simulation import Simulation
from pardem.testing import head_on_probes, measure

D, M, V = 0.01, 1e-3, 0.1  # diameter (m), mass (kg), approach speed (m/s) of the two disks
E, NU = 1e7, 0.3  # Young's modulus (Pa), Poisson's ratio
E_STAR = E / (2 * (1 - NU**2))
R_STAR, M_RED = D / 4, M / 2


def collision(contact: dict, dt: float, damping: bool = False):
    """Two equal disks meeting head on at V; ``(sim, overlap, approach)`` as testing.two_disks."""
    ps = [{"x": -(D + 1e-5) / 2, "y": 0.0, "vx": V / 2, "diameter": D, "mass": M},
          {"x": (D + 1e-5) / 2, "y": 0.0, "vx": -V / 2, "diameter": D, "mass": M}]
    effects = {"normal_damping": damping, "tangential_friction": False, "rotation": False,
               "bottom_friction": False}
    sim = Simulation(scene_from_dict({
        "scene": {"name": "two-disks", "kind": "free"}, "particles": ps, "effects": effects,
        "contact": contact, "time": {"dt": dt, "end": 1.0}}))
    return (sim, *head_on_probes(D))


def hertz_contact_time() -> float:
    """The undamped Hertz collision's duration from energy conservation (independent of the
    code): m_red v^2/2 = (8/15) E* sqrt(R*) delta^(5/2) at the deepest overlap delta_m, and
    t_c = 2 (delta_m/v) int_0^1 dx / sqrt(1 - x^(5/2)), the integral by the trapezoid rule
    after x = 1 - u^2 (which removes the end point's singularity)."""
    delta_m = (15 * M_RED * V**2 / (16 * E_STAR * math.sqrt(R_STAR))) ** 0.4
    u = np.linspace(1e-6, 1.0, 200_001)
    integrand = 2 * u / np.sqrt(1 - (1 - u * u) ** 2.5)
    integral = float(np.sum(0.5 * (integrand[1:] + integrand[:-1]) * np.diff(u)))
    return 2 * delta_m / V * integral


HERTZ = {"normal": "hertz", "youngs_modulus": E, "poisson_ratio": NU}


def test_hertz_collision_time_restitution_and_energy():
    t_ref = hertz_contact_time()
    # the textbook constant: t_c = 2.8683 (m_red^2/(R* E*^2 v))^(1/5) for this force law
    assert t_ref == pytest.approx(2.8683 * (M_RED**2 / (R_STAR * E_STAR**2 * V)) ** 0.2, rel=1e-4)
    sim, overlap, approach = collision(HERTZ, dt=1e-6)
    e0 = sim.total_energy()
    t_c, e_n = measure(sim, overlap, approach)
    assert t_c == pytest.approx(t_ref, rel=2e-3)
    assert e_n == pytest.approx(1.0, abs=1e-3)
    assert sim.total_energy() == pytest.approx(e0, rel=1e-3)


def test_hertz_energy_is_conserved_during_the_contact():
    sim, overlap, _ = collision(HERTZ, dt=1e-6)
    e0 = sim.total_energy()
    deepest, worst = 0.0, 0.0
    for _ in range(2500):
        sim.advance_steps(1)
        deepest = max(deepest, overlap(sim))
        worst = max(worst, abs(sim.total_energy() / e0 - 1))
    # the overlap went to the depth energy conservation predicts, the stored energy counted
    delta_m = (15 * M_RED * V**2 / (16 * E_STAR * math.sqrt(R_STAR))) ** 0.4
    assert deepest == pytest.approx(delta_m, rel=1e-3)
    assert worst < 1e-3


def test_hertz_tangential_stiffness_follows_the_contact_radius():
    """Mindlin: k_t = 8 G* sqrt(R* delta), G* = G/(2 (2 - nu)), G = E/(2 (1 + nu)); a sticking
    spring after one step of tangential velocity u carries f_t = k_t u dt."""
    from pardem.contact.model import law_params
    from pardem.input.scene import Contact

    law = law_params(Contact(**HERTZ), 1e-5)
    g_star = E / (2 * (1 + NU)) / (2 * (2 - NU))
    for delta in (1e-6, 4e-6):
        force, _ = contact_law((1.0, 0.0), delta, (0.0, 1e-3), (0.0, 0.0), 0.0, 0.0, R_STAR,
                               (0.0, 0.0), law, ContactOptions(damping=False, normal=1))
        k_t = 8 * g_star * math.sqrt(R_STAR * delta)
        assert force.fty == pytest.approx(-k_t * 1e-3 * 1e-5, rel=1e-12)
        assert force.fn == pytest.approx(4 / 3 * E_STAR * math.sqrt(R_STAR) * delta**1.5,
                                       rel=1e-12)


@pytest.mark.parametrize("extra, message", [
    ({"k_n": 100.0}, 'k_n = 100.0: is a parameter of normal = "linear"'),
    ({"k_t": 100.0}, 'normal = "hertz" sets the tangential stiffness'),
])
def test_a_key_of_another_law_is_refused_with_the_law_named(extra, message):
    with pytest.raises(SceneError, match=message):
        collision({**HERTZ, **extra}, dt=1e-6)


def test_hertz_parameters_with_the_linear_law_are_refused():
    with pytest.raises(SceneError, match='youngs_modulus = 10000000.0: is a parameter of '
                                         'normal = "hertz"; this scene\'s normal law is "linear"'):
        collision({"youngs_modulus": E}, dt=1e-6)
    with pytest.raises(SceneError, match=r'poisson_ratio: missing \(required with normal = '
                                         r'"hertz"\)'):
        collision({"normal": "hertz", "youngs_modulus": E}, dt=1e-6)


def test_a_hertz_scene_round_trips_through_its_toml():
    sim, _, _ = collision(HERTZ, dt=1e-6)
    text = scene_to_toml(sim.scene)
    assert scene_from_dict(tomllib.loads(text)).to_dict() == sim.scene.to_dict()
    assert "k_n" not in tomllib.loads(text)["contact"]


K1 = 352.1  # loading stiffness (N/m), the paper's k_n


def luding(k2: float, kc: float) -> dict:
    return {"normal": "luding", "k_n": K1, "k_unload": k2, "k_adhesion": kc}


def luding_restitution(k2: float, kc: float) -> float:
    """e = sqrt(a - (1 - a)^2 (k_2/k_1) k_c/(k_2 + k_c)), a = k_1/k_2 (Luding 2008), from the
    work along the loading, unloading and tension branches."""
    a = K1 / k2
    return math.sqrt(a - (1 - a) ** 2 * (k2 / K1) * kc / (k2 + kc))


@pytest.mark.parametrize("k2, kc", [(2 * K1, 0.0), (2 * K1, 0.5 * K1), (5 * K1, 0.2 * K1),
                                    (K1, 0.0)])
def test_luding_restitution_without_damping(k2, kc):
    # k_c = 0: e = sqrt(k_1/k_2); k_2 = k_1: elastic, e = 1
    expected = luding_restitution(k2, kc)
    if kc == 0:
        assert expected == pytest.approx(math.sqrt(K1 / k2), rel=1e-14)
    t_load = math.pi / 2 * math.sqrt(M_RED / K1)
    sim, overlap, approach = collision(luding(k2, kc), dt=t_load / 2000)
    _, e_n = measure(sim, overlap, approach)
    assert e_n == pytest.approx(expected, abs=2e-3)


def test_luding_captures_a_pair_when_damping_is_on():
    """k_2 = 2 k_1, k_c = 2 k_1: undamped the pair still separates (e^2 = 1/4); with damping
    of e_n ~ 0.3 in the linear law (gamma_n = 0.3 kg/s) it loses more than the adhesion lets go, and stays
    together, oscillating down into the well of the tension branch."""
    params = luding(2 * K1, 2 * K1)
    assert luding_restitution(2 * K1, 2 * K1) == pytest.approx(0.5)
    dt = math.pi / 2 * math.sqrt(M_RED / K1) / 1000
    sim, overlap, approach = collision(params, dt=dt)
    _, e_n = measure(sim, overlap, approach)
    assert e_n == pytest.approx(0.5, abs=3e-3)
    sim, overlap, _ = collision({**params, "gamma_n": 0.3}, dt=dt, damping=True)
    overlaps = []
    for _ in range(40):
        sim.advance_steps(500)
        overlaps.append(overlap(sim))
    assert min(overlaps[2:]) > 0  # touching from the first contact on, for ~10 t_c
    assert abs(sim.gathered("velocity")["velocity"][0, 0]) < 0.02 * V / 2


def test_luding_unloading_path_by_hand():
    """Load to 1 mm, unload to 0.6 mm and 0.1 mm, reload to 0.8 mm: the branches' forces."""
    from pardem.contact.model import law_params
    from pardem.input.scene import Contact

    k2, kc = 2 * K1, 0.5 * K1
    law = law_params(Contact(**luding(k2, kc)), 1e-5)
    o = ContactOptions(damping=False, friction=False, normal=2)
    d0 = 0.5e-3  # (1 - k_1/k_2) delta_max
    hn, forces = 0.0, []
    for delta in (0.5e-3, 1e-3, 0.6e-3, 0.1e-3, 0.8e-3):
        force, history = contact_law((1.0, 0.0), delta, (0.0, 0.0), (0.0, 0.0), 0.0, hn, R_STAR,
                                     (0.0, 0.0), law, o)
        hn = history.hn
        forces.append(force.fn)
    # at 0.1 mm k_2 (delta - d0) = -0.2816 N pulls harder than -k_c delta = -0.0176 N: capped,
    # delta_max moves to delta (k_2 + k_c)/(k_2 - k_1) = 0.25 mm; reloading to 0.8 mm passes it
    expected = [K1 * 0.5e-3, K1 * 1e-3, k2 * (0.6e-3 - d0), -kc * 0.1e-3, K1 * 0.8e-3]
    assert forces == pytest.approx(expected, rel=1e-12)


def test_luding_keys_are_checked():
    with pytest.raises(SceneError, match="k_unload = 100.0: must be >= k_n = 352.1"):
        collision(luding(100.0, 0.0), dt=1e-6)
    with pytest.raises(SceneError, match=r'k_unload: missing \(required with normal = "luding"'):
        collision({"normal": "luding"}, dt=1e-6)
    with pytest.raises(SceneError, match='k_unload = 700.0: is a parameter of normal = "luding"'):
        collision({**HERTZ, "k_unload": 700.0}, dt=1e-6)

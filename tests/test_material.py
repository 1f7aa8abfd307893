"""Material as a physicist gives it. Damping as a restitution ([contact] restitution = e_n):
every contact of the linear law rebounds with that e_n whatever its masses (gamma_n = beta
sqrt(k_n m_red) per contact), against the analytic damped spring; per pair of species and
mixed; refused where it has no meaning. Masses from a density ([[species]] density)."""

import math

import numpy as np
import pytest
from helpers import D_SMALL, K_N, M_SMALL, collisions, couette_scene, free_scene, head_on, wall_setup

from pardem.contact.pairs import pair_table
from pardem.contact.params import LAW_COLUMNS
from pardem.input.scene import SceneError
from pardem.input.scene_file import load_scene, write_scene
from pardem.simulation import Simulation
from pardem.testing import measure

DAMPED = {"normal_damping": True}
FRICTIONLESS = {"k_t": 0.0, "mu": 0.0, "gamma_n": None}


def contact_time(e: float, m_red: float, k: float = K_N) -> float:
    """t_c of the damped linear spring whose restitution is e: omega_d = omega_0 pi /
    sqrt(pi^2 + ln^2 e) (from e = exp(-pi eta/omega_d), omega_d^2 = omega_0^2 - eta^2)."""
    return math.sqrt(math.pi ** 2 + math.log(e) ** 2) / math.sqrt(k / m_red)


def test_disks_of_any_masses_rebound_with_the_given_restitution():
    """Pairs of masses (m, 2m) and (m, 8m) at e_n = 0.7: both rebound with 0.7 and last the
    damped spring's t_c of their own reduced mass."""
    rows = (head_on(0.0, (0, 0), (M_SMALL, 2 * M_SMALL))
            + head_on(0.05, (0, 0), (M_SMALL, 8 * M_SMALL)))
    sim = Simulation(free_scene(rows, effects=DAMPED,
                                contact={**FRICTIONLESS, "restitution": 0.7}))
    (t_a, e_a), (t_b, e_b) = collisions(sim, [(0, 1), (2, 3)])
    assert e_a == pytest.approx(0.7, rel=1e-2) and e_b == pytest.approx(0.7, rel=1e-2)
    assert t_a == pytest.approx(contact_time(0.7, 2 * M_SMALL / 3), rel=2e-3)
    assert t_b == pytest.approx(contact_time(0.7, 8 * M_SMALL / 9), rel=2e-3)


@pytest.mark.parametrize("target", ["flat", "disk"])
def test_a_disk_rebounds_off_a_ring_with_the_given_restitution(target):
    """Against the inner ring (its flat surface, or a wall disk), infinitely massive: m_red is
    the disk's mass."""
    sim, overlap, speed = wall_setup(target, contact={"restitution": 0.6})
    t, e = measure(sim, overlap, speed)
    assert e == pytest.approx(0.6, rel=5e-2)
    assert t == pytest.approx(contact_time(0.6, M_SMALL), rel=5e-2)


def test_restitution_per_pair_of_species_and_mixed():
    """[contact] restitution 0.9 with a table for species 0-1 at 0.5: that pair rebounds with
    0.5, a pair of species 0 with 0.9; species 2's own law at 0.4 and no 0-2 table: that pair
    rebounds with sqrt(0.9 * 0.4) = 0.6 (the mixing rule)."""
    rows = (head_on(0.0, (0, 1), (M_SMALL, M_SMALL)) + head_on(0.05, (0, 0), (M_SMALL, M_SMALL))
            + head_on(0.1, (0, 2), (M_SMALL, 3 * M_SMALL)))
    pairs = [{"species": [0, 1], "restitution": 0.5}, {"species": [2, 2], "restitution": 0.4}]
    sim = Simulation(free_scene(rows, effects=DAMPED, contact={**FRICTIONLESS,
                                                               "restitution": 0.9,
                                                               "pair": pairs}))
    (_, e_01), (_, e_00), (t_02, e_02) = collisions(sim, [(0, 1), (2, 3), (4, 5)])
    assert e_01 == pytest.approx(0.5, rel=1e-2)
    assert e_00 == pytest.approx(0.9, rel=1e-2)
    assert e_02 == pytest.approx(0.6, rel=1e-2)
    assert t_02 == pytest.approx(contact_time(0.6, 3 * M_SMALL / 4), rel=2e-3)


def test_a_scene_with_a_restitution_round_trips_without_gamma_n(tmp_path):
    scene = couette_scene(counts=(20, 5), contact={"restitution": 0.8})
    write_scene(scene, tmp_path / "s.toml")
    assert "gamma_n" not in (tmp_path / "s.toml").read_text()
    assert load_scene(tmp_path / "s.toml") == scene
    plain = couette_scene(counts=(20, 5))
    assert "restitution" not in plain.to_dict()["contact"]


BAD = [
    ({"restitution": 0.8, "gamma_n": 0.1}, {}, "restitution = 0.8: gamma_n is given too"),
    ({"restitution": 1.5}, {}, "restitution = 1.5: must be <= 1"),
    ({"restitution": 0.0}, {}, "restitution = 0.0: must be > 0"),
    ({"restitution": 0.8}, {"normal_damping": False},
     "restitution = 0.8: is set but [effects] normal_damping is off"),
    ({"restitution": 0.8, "normal": "hertz", "youngs_modulus": 1e7, "poisson_ratio": 0.3},
     {}, 'restitution = 0.8: is defined for normal = "linear"'),
    ({"pair": [{"species": ["small", "large"], "restitution": 0.5}]}, {},
     "[[contact.pair]] #0 'small'-'large' restitution = 0.5: needs [contact] restitution"),
    ({"tangential_restitution": 0.5}, {},
     "tangential_restitution = 0.5: is set but [effects] tangential_damping is off"),
    ({"tangential_restitution": 0.5, "gamma_t": 0.1}, {"tangential_damping": True},
     "tangential_restitution = 0.5: gamma_t is given too"),
    ({"tangential_restitution": 0.5}, {"tangential_damping": True, "rotation": False},
     "tangential_restitution = 0.5: assumes turning disks"),
    ({"tangential_restitution": 0.5, "normal": "hertz", "youngs_modulus": 1e7,
      "poisson_ratio": 0.3}, {"tangential_damping": True},
     'tangential_restitution = 0.5: needs a constant k_t; normal = "hertz"'),
    ({"pair": [{"species": ["small", "large"], "tangential_restitution": 0.5}],
      "gamma_t": 0.1}, {"tangential_damping": True},
     "'small'-'large' tangential_restitution = 0.5: needs [contact] tangential_restitution"),
]


@pytest.mark.parametrize("contact, effects, message", BAD)
def test_a_restitution_where_it_has_no_meaning_is_refused(contact, effects, message):
    if "normal" in contact:  # a Hertz scene gives no k_n
        with pytest.raises(SceneError) as e:
            d = couette_scene(counts=(20, 5)).to_dict()
            d["contact"] = {k: v for k, v in d["contact"].items() if k not in ("k_n", "k_t", "gamma_n", "gamma_t")}
            d["contact"].update(contact)
            d["effects"].update(effects)
            from pardem.input.schema import scene_from_dict

            scene_from_dict(d)
    else:
        with pytest.raises(SceneError) as e:
            couette_scene(counts=(20, 5), contact=contact, effects=effects)
    assert message in str(e.value)


def test_a_species_mass_from_its_density_and_the_disks_height():
    """The paper's small disk (d = 7.42 mm, m = 0.275 g) at h = 6 mm is a material of
    m / (pi (d/2)^2 h) = 1060.1 kg/m^3; given that density, the species gets that mass, and
    the run's particles carry it."""
    rho = M_SMALL / (math.pi * (D_SMALL / 2) ** 2 * 6e-3)
    d = couette_scene(counts=(30, 5)).to_dict()
    d["species"][0] = {"name": "small", "diameter": D_SMALL, "density": rho, "count": 30}
    from pardem.input.schema import scene_from_dict

    scene = scene_from_dict(d)
    assert scene.species[0].mass == pytest.approx(M_SMALL, rel=1e-12)
    assert scene.species[0].density == rho
    sim = Simulation(scene)
    mass = sim.gathered("mass")["mass"][sim.gathered("kind")["kind"] == 0]
    assert np.count_nonzero(np.isclose(mass, M_SMALL, rtol=1e-12, atol=0.0)) == 30


@pytest.mark.parametrize("row, message", [
    ({"mass": M_SMALL, "density": 1000.0}, "density = 1000.0: mass is given too"),
    ({}, "[[species]] #0 mass: missing (give mass in kg, or density in kg/m^3"),
    ({"density": -1.0}, "density = -1.0: must be > 0"),
])
def test_mass_and_density_one_of_them(row, message):
    d = couette_scene(counts=(30, 5)).to_dict()
    d["species"][0] = {"name": "small", "diameter": D_SMALL, "count": 30, **row}
    from pardem.input.schema import scene_from_dict

    with pytest.raises(SceneError) as e:
        scene_from_dict(d)
    assert message in str(e.value)


def tangential_speeds(sim, i: int, j: int) -> float:
    """The tangential speed (m/s) of the contact point of i on j: (v_i - v_j) . t -
    (a_i w_i + a_j w_j), t = z x n, n the unit vector from j to i."""
    g = sim.gathered("position", "velocity", "omega", "radius")
    x, v, w, a = g["position"], g["velocity"], g["omega"], g["radius"]
    n = (x[i] - x[j]) / np.hypot(*(x[i] - x[j]))
    return float((v[i] - v[j]) @ np.array([-n[1], n[0]]) - (a[i] * w[i] + a[j] * w[j]))


def extreme_ratios(series: list[float]) -> list[float]:
    """Ratios of successive extreme magnitudes of a sampled damped oscillation, each extreme
    placed by the parabola through its sample and the two beside it."""
    s, peaks = np.asarray(series), []
    for k in range(1, len(s) - 1):
        if abs(s[k]) >= abs(s[k - 1]) and abs(s[k]) > abs(s[k + 1]):
            y0, y1, y2 = abs(s[k - 1]), abs(s[k]), abs(s[k + 1])
            peaks.append(y1 + (y2 - y0) ** 2 / (8 * (2 * y1 - y0 - y2)))
    return [b / a for a, b in zip(peaks, peaks[1:])]


def damped_ratio(zeta: float) -> float:
    """The ratio of successive extremes of a damped oscillator's speed (its restitution)."""
    return math.exp(-math.pi * zeta / math.sqrt(1 - zeta ** 2))


@pytest.mark.parametrize("integrator, e_t", [("verlet-halfstep", 0.5),
                                             ("verlet-halfstep", 0.8), ("verlet", 0.5)])
def test_a_sticking_contact_oscillates_with_the_given_tangential_restitution(integrator, e_t):
    """Two disks pressed together (overlap 0.7 % of d, at rest normally) with a small
    tangential contact-point speed: the contact sticks (mu |f_n| far above k_t xi) and the
    contact point oscillates, damped. The speed's successive extremes fall by e_t each half
    period, for a pair of masses (m, m) and one of (m, 4m): a sticking contact of two turning
    disks has the mass m_red/3 whatever the masses (1/m_i + 1/m_j + a_i^2/I_i + a_j^2/I_j, I =
    m a^2/2). k_t = 100 k_n makes the oscillation ~17 times faster than the normal one, so the
    first extremes come while f_n is near its peak.
    The half-step integrator increments the spring with the velocity that moves the disks: it
    gives e_t. The default one increments it with the velocity predicted at the step's end,
    half a step ahead, which adds the damping k_t dt/2 (docs/design.md): zeta + omega_t dt/4."""
    rows = []
    for y, m_j in ((0.0, M_SMALL), (0.05, 4 * M_SMALL)):
        for side, m, vy in ((-1, M_SMALL, 0.005), (1, m_j, -0.005)):
            rows.append({"x": side * (D_SMALL - 5e-5) / 2, "y": y, "vy": vy,
                         "diameter": D_SMALL, "mass": m})
    k_t, dt = 100 * K_N, 5e-6
    sim = Simulation(free_scene(
        rows, effects={"tangential_friction": True, "tangential_damping": True, "rotation": True},
        contact={"gamma_n": None, "k_t": k_t, "mu": 2.0, "tangential_restitution": e_t},
        time={"dt": dt, "integrator": integrator}))
    speeds = {(0, 1): [], (2, 3): []}
    for _ in range(300):
        sim.advance_steps(1)
        for pair, s in speeds.items():
            s.append(tangential_speeds(sim, *pair))
    zeta = -math.log(e_t) / math.hypot(math.pi, math.log(e_t))
    for m_j, s in zip((M_SMALL, 4 * M_SMALL), speeds.values()):
        m_red = M_SMALL * m_j / (M_SMALL + m_j)
        omega_t = math.sqrt(3 * k_t / m_red)
        expected = e_t if integrator == "verlet-halfstep" else damped_ratio(zeta + omega_t * dt / 4)
        ratios = extreme_ratios(s)[:4]
        assert len(ratios) == 4
        assert ratios == pytest.approx([expected] * 4, rel=1e-2)


def test_a_mixed_pair_gets_the_geometric_mean_of_the_tangential_restitutions():
    """[contact] e_t 0.9, species 2's own law 0.4, no 0-2 table: the 0-2 contacts damp as
    e_t = sqrt(0.9 * 0.4) = 0.6, i.e. the table's gamma_t column holds beta(0.6) =
    2L/sqrt(pi^2 + L^2), L = -ln 0.6 (damping.py), and species 0's own contacts beta(0.9)."""
    rows = (head_on(0.0, (0, 0), (M_SMALL, M_SMALL)) + head_on(0.05, (2, 2), (M_SMALL, M_SMALL)))
    scene = free_scene(rows, effects={"tangential_friction": True, "tangential_damping": True,
                                      "rotation": True},
                       contact={"tangential_restitution": 0.9,
                                "pair": [{"species": [2, 2], "tangential_restitution": 0.4}]})
    table = pair_table(scene, 1e-5)
    column = LAW_COLUMNS.index("gamma_t")

    def beta(e):
        return 2 * -math.log(e) / math.hypot(math.pi, math.log(e))

    assert table[0, 2, column] == pytest.approx(beta(0.6), rel=1e-12)
    assert table[0, 0, column] == pytest.approx(beta(0.9), rel=1e-12)
    assert table[2, 2, column] == pytest.approx(beta(0.4), rel=1e-12)

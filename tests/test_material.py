"""Material as a physicist gives it. Damping as a restitution ([contact] restitution = e_n):
every contact of the linear law rebounds with that e_n whatever its masses (gamma_n = beta
sqrt(k_n m_red) per contact), against the analytic damped spring; per pair of species and
mixed; refused where it has no meaning. Masses from a density ([[species]] density)."""

import math

import numpy as np
import pytest
from helpers import D_SMALL, K_N, M_SMALL, collisions, couette_scene, free_scene, head_on, wall_setup

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
]


@pytest.mark.parametrize("contact, effects, message", BAD)
def test_a_restitution_where_it_has_no_meaning_is_refused(contact, effects, message):
    if "normal" in contact:  # a Hertz scene gives no k_n
        with pytest.raises(SceneError) as e:
            d = couette_scene(counts=(20, 5)).to_dict()
            d["contact"] = {k: v for k, v in d["contact"].items() if k not in ("k_n", "k_t", "gamma_n")}
            d["contact"].update(contact)
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

"""Contact parameters per pair of species ([[contact.pair]]): each pair collides with its own
law, measured against the analytic damped spring; pairs without a table mix their partners'
own laws (springs and dashpots in series, Hertz's two-material E*); the time step follows the
stiffest pair; bad tables are refused by name."""

import math

import h5py
import numpy as np
import pytest
from helpers import (GAMMA_N, K_N, M_SMALL, analytic_collision, collisions, couette_scene,
                     free_scene, head_on, wall_setup)

from pardem.contact.params import LAW_COLUMNS
from pardem.contact.pairs import pair_table
from pardem.input.scene import SceneError
from pardem.input.schema import scene_from_dict
from pardem.input.scene_file import load_scene, write_scene
from pardem.simulation import Simulation

STIFF = {"species": [0, 1], "k_n": 4 * K_N, "gamma_n": 0.5 * GAMMA_N}


def test_a_pair_table_gives_its_pair_its_own_contact_time_and_restitution():
    """Species 0 and 1 meet with k_n = 4 k and gamma_n / 2 (the pair table), two disks of
    species 0 beside them with the [contact] law; each pair's t_c = pi/omega and e_n =
    exp(-pi eta/omega) of its own spring and reduced mass, and the automatic step is t_c/50 of
    the stiffer pair."""
    rows = head_on(0.0, (0, 1), (M_SMALL, 2 * M_SMALL)) + head_on(0.05, (0, 0),
                                                                   (M_SMALL, M_SMALL))
    sim = Simulation(free_scene(rows, effects={"normal_damping": True},
                                contact={"k_t": 0.0, "mu": 0.0, "pair": [STIFF]}))
    tc_ab, e_ab = analytic_collision(2 * M_SMALL / 3, 4 * K_N, 0.5 * GAMMA_N)
    tc_aa, e_aa = analytic_collision(M_SMALL / 2, K_N, GAMMA_N)
    assert tc_ab < tc_aa / 1.5
    assert 0.99 * tc_ab / 50 <= sim.dt <= tc_ab / 50
    (t_ab, r_ab), (t_aa, r_aa) = collisions(sim, [(0, 1), (2, 3)])
    assert t_ab == pytest.approx(tc_ab, rel=2e-3) and r_ab == pytest.approx(e_ab, rel=1e-2)
    assert t_aa == pytest.approx(tc_aa, rel=2e-3) and r_aa == pytest.approx(e_aa, rel=1e-2)


def test_a_pair_without_a_table_collides_with_its_partners_laws_in_series():
    """Species 0 has its own law (k_n = 4 k, gamma_n / 2), species 1 the [contact] one, and the
    pair 0-1 has no table: it collides as the two half-contacts in series, k = 2 k_a k_b /
    (k_a + k_b) = 1.6 k and gamma_n likewise, with its reduced mass (t_c and e_n of that
    spring), while the pair 1-1 keeps the [contact] law."""
    own = {"species": [0, 0], "k_n": 4 * K_N, "gamma_n": 0.5 * GAMMA_N}
    rows = head_on(0.0, (0, 1), (M_SMALL, 2 * M_SMALL)) + head_on(0.05, (1, 1),
                                                                   (M_SMALL, M_SMALL))
    sim = Simulation(free_scene(rows, effects={"normal_damping": True},
                                contact={"k_t": 0.0, "mu": 0.0, "pair": [own]}))
    k_ab = 1.0 / (0.5 / (4 * K_N) + 0.5 / K_N)  # two half-springs 2 k_a, 2 k_b in series
    g_ab = 1.0 / (0.5 / (0.5 * GAMMA_N) + 0.5 / GAMMA_N)
    tc_ab, e_ab = analytic_collision(2 * M_SMALL / 3, k_ab, g_ab)
    tc_bb, e_bb = analytic_collision(M_SMALL / 2, K_N, GAMMA_N)
    (t_ab, r_ab), (t_bb, r_bb) = collisions(sim, [(0, 1), (2, 3)])
    assert t_ab == pytest.approx(tc_ab, rel=2e-3) and r_ab == pytest.approx(e_ab, rel=1e-2)
    assert t_bb == pytest.approx(tc_bb, rel=2e-3) and r_bb == pytest.approx(e_bb, rel=1e-2)


def test_hertz_species_mix_by_the_two_material_formula_and_friction_geometrically():
    """Two Hertz species of different E, nu and mu and no pair table between them: the pair's
    E* is 1/E* = (1 - nu_a^2)/E_a + (1 - nu_b^2)/E_b (contact mechanics of two materials),
    G* likewise with G = E/(2(1 + nu)) and (2 - nu)/G, mu = sqrt(mu_a mu_b); a species with
    itself keeps its own law exactly."""
    (e_a, nu_a, mu_a), (e_b, nu_b, mu_b) = (2e7, 0.3, 0.4), (5e6, 0.45, 0.1)
    tables = [{"species": [0, 0], "youngs_modulus": e_a, "poisson_ratio": nu_a, "mu": mu_a},
              {"species": [1, 1], "youngs_modulus": e_b, "poisson_ratio": nu_b, "mu": mu_b}]
    rows = head_on(0.0, (0, 1), (M_SMALL, M_SMALL))
    d = free_scene(rows).to_dict()
    d["contact"] = {"normal": "hertz", "youngs_modulus": 1e7, "poisson_ratio": 0.3,
                    "mu": 0.5, "pair": tables}
    scene = scene_from_dict(d)
    table = pair_table(scene, 1e-6)
    col = {k: LAW_COLUMNS.index(k) for k in ("k_n", "k_t", "mu")}
    e_star = 1.0 / ((1 - nu_a**2) / e_a + (1 - nu_b**2) / e_b)
    g_a, g_b = e_a / (2 * (1 + nu_a)), e_b / (2 * (1 + nu_b))
    g_star = 1.0 / ((2 - nu_a) / g_a + (2 - nu_b) / g_b)
    assert table[0, 1, col["k_n"]] == pytest.approx(4 / 3 * e_star, rel=1e-12)
    assert table[0, 1, col["k_t"]] == pytest.approx(8 * g_star, rel=1e-12)
    assert table[0, 1, col["mu"]] == pytest.approx(math.sqrt(mu_a * mu_b), rel=1e-12)
    assert table[0, 0, col["k_n"]] == 4 / 3 * e_a / (2 * (1 - nu_a**2))
    assert table[1, 1, col["mu"]] == mu_b


@pytest.mark.parametrize("target", ["flat", "disk"])
def test_a_species_ring_table_sets_the_contact_with_the_ring(target):
    """A small disk against the inner ring (its flat surface, or one of its wall disks) with
    the small-inner_ring table's k_n = 4 k: t_c and e_n of that spring with the disk's own
    mass (the ring is infinitely massive), and the step follows this stiffest contact."""
    pair = {"species": ["small", "inner_ring"], "k_n": 4 * K_N}
    tc, e = analytic_collision(M_SMALL, 4 * K_N)
    sim, overlap, speed = wall_setup(target, contact={"pair": [pair]})
    assert 0.99 * tc / 50 <= sim.dt <= tc / 50
    from pardem.testing import measure

    got_t, got_e = measure(sim, overlap, speed)
    assert abs(got_t / tc - 1) < 0.05 and abs(got_e / e - 1) < 0.05


def test_a_scene_with_pair_tables_round_trips_and_differs_from_one_without(tmp_path):
    """Written and read back, a scene keeps its pair tables (in the order of the scene's
    species, a ring second); they are part of the physics a checkpoint must match, and a scene
    without them writes no pair key (its fingerprint is that of older pardem)."""
    pairs = [{"species": ["large", "small"], "mu": 0.3},
             {"species": ["outer_ring", "large"], "k_n": 500.0, "gamma_n": 0.1}]
    scene = couette_scene(counts=(20, 5), contact={"pair": pairs})
    plain = couette_scene(counts=(20, 5))
    write_scene(scene, tmp_path / "s.toml")
    back = load_scene(tmp_path / "s.toml")
    assert back == scene and back.fingerprint() == scene.fingerprint()
    assert [p.species for p in back.pairs] == [("small", "large"), ("large", "outer_ring")]
    assert scene.fingerprint() != plain.fingerprint()
    assert "pair" not in plain.to_dict()["contact"]


BAD = [
    ({"species": ["small", "huge"], "mu": 0.3}, "'huge' is not a species"),
    ({"species": ["small"], "mu": 0.3}, "expected a list of two partners"),
    ({"species": ["inner_ring", "outer_ring"], "mu": 0.3}, "two rings never touch"),
    ({"species": ["small", "large"], "friction": 0.3}, "unknown key 'friction'"),
    ({"species": ["small", "large"], "gravity": 1.0}, "gravity = 1.0: is a property of the scene"),
    ({"species": ["small", "large"], "k_unload": 900.0}, 'k_unload = 900.0: is a parameter of '
                                                          'normal = "luding"'),
    ({"species": ["small", "large"], "k_r": 5.0}, "k_r = 5.0: is set but [effects] "
                                                  "rolling_resistance is off"),
    ({"species": ["small", "large"], "k_n": -1.0}, "k_n = -1.0: must be > 0"),
    ({"species": ["small", "large"]}, "no parameters"),
]


@pytest.mark.parametrize("table, message", BAD)
def test_bad_pair_tables_are_refused_naming_the_pair_and_the_key(table, message):
    with pytest.raises(SceneError) as e:
        couette_scene(counts=(20, 5), contact={"pair": [table]})
    assert "[[contact.pair]] #0" in str(e.value) and message in str(e.value)


def test_a_pair_given_twice_and_a_ring_in_a_free_scene_are_refused():
    twice = [{"species": ["small", "large"], "mu": 0.3}, {"species": ["large", "small"],
                                                          "mu": 0.2}]
    with pytest.raises(SceneError, match=r"#1 'small'-'large': the pair is given twice"):
        couette_scene(counts=(20, 5), contact={"pair": twice})
    rows = head_on(0.0, (0, 1), (M_SMALL, M_SMALL))
    with pytest.raises(SceneError, match="'inner_ring' is not a species"):
        free_scene(rows, contact={"pair": [{"species": [0, "inner_ring"], "mu": 0.1}]})
    rows[1]["species"] = 1.5
    with pytest.raises(SceneError, match="species = 1.5: must be an integer"):
        free_scene(rows)


def by_id(sim):
    """Every particle's species (one rank), ordered by id."""
    n = int(sim.clock.n_local[0])
    return sim.ps.species[:n][np.argsort(sim.ps.gid[:n])]


def test_a_checkpoint_without_species_restarts_with_the_scenes(tmp_path):
    """A checkpoint written before particles carried a species (no ``species`` dataset)
    restarts with each particle's species from the scene (by id), the same as a checkpoint
    that has them."""
    pairs = [{"species": ["small", "large"], "k_n": 700.0}]
    scene = couette_scene(counts=(30, 10), contact={"pair": pairs},
                          effects={"tangential_friction": False, "bottom_friction": False})
    sim = Simulation(scene, out_dir=tmp_path / "run")
    sim.advance_steps(50)
    sim.write_checkpoint()
    path = tmp_path / "run" / "checkpoint.h5"
    species = by_id(sim)
    assert set(species[:sim.n_free]) == {0, 1} and set(species[sim.n_free:]) <= {2, 3}
    with h5py.File(path, "a") as h5:
        np.testing.assert_array_equal(h5["species"][()], species)
        del h5["species"]
    again = Simulation(scene, restart=path)
    np.testing.assert_array_equal(by_id(again), species)
    assert math.isfinite(again.time)

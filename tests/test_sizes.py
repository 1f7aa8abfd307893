"""Continuous size distributions of a couette scene's species ([[species]]
diameter_distribution): the drawn diameters against the distributions' moments, masses from
the density per disk, the seed, the time step from the lightest drawn pair, refused input."""

import math

import numpy as np
import pytest
from helpers import couette_scene

from pardem.check import volume_fraction
from pardem.core.scales import smallest_contact_time
from pardem.core.timestep import resolve_dt
from pardem.input.placement import initial_configuration
from pardem.input.sanity import density_warning
from pardem.input.scene import SceneError, Species
from pardem.input.scene_file import load_scene, write_scene
from pardem.input.schema import scene_from_dict
from pardem.input.species import species_disks
from pardem.simulation import Simulation

RHO = 1060.0  # kg/m^3, the paper's small disks at h = 6 mm
H = 6e-3
K_N, GAMMA_N = 352.1, 0.19  # the [contact] defaults
UNIFORM = {"diameter_distribution": "uniform", "diameter_min": 6e-3, "diameter_max": 9e-3}
LOGNORMAL = {"diameter_distribution": "lognormal", "diameter_median": 7.5e-3,
             "diameter_sigma": 0.15}
SMALL_CELL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
              "compression_time": 0.1, "omega_inner": 1.0}


def scene_of(*rows, seed=3, geometry=None, **tables):
    """A couette scene whose [[species]] are ``rows`` (density RHO unless given)."""
    d = couette_scene(counts=(30, 5)).to_dict()
    d["scene"]["seed"] = seed
    d["geometry"].update(geometry or {})
    d["species"] = [{"name": f"s{i}", **({} if "mass" in r else {"density": RHO}), **r}
                    for i, r in enumerate(rows)]
    d.update(tables)
    return scene_from_dict(d)


def test_uniform_diameters_have_the_uniform_mean_and_variance():
    """N = 2000 draws on [a, b): mean (a+b)/2 within 4 standard errors (b-a)/sqrt(12 N);
    variance (b-a)^2/12 within 4 standard errors of a sample variance, sqrt((mu_4 -
    sigma^4)/N) with mu_4 = (b-a)^4/80 for the uniform distribution."""
    n, a, b = 2000, UNIFORM["diameter_min"], UNIFORM["diameter_max"]
    d = species_disks(scene_of({**UNIFORM, "count": n}))[0][0]
    assert d.size == n and d.min() >= a and d.max() < b
    assert abs(d.mean() - (a + b) / 2) < 4 * (b - a) / math.sqrt(12 * n)
    se_var = (b - a) ** 2 * math.sqrt((1 / 80 - 1 / 144) / n)
    assert abs(d.var(ddof=1) - (b - a) ** 2 / 12) < 4 * se_var


def test_lognormal_log_diameters_have_the_median_and_sigma():
    """ln d of N = 2000 draws: mean ln(median) within 4 sigma/sqrt(N); standard deviation
    sigma within 4 sigma/sqrt(2 (N-1)), the normal sample's."""
    n, median, sigma = 2000, LOGNORMAL["diameter_median"], LOGNORMAL["diameter_sigma"]
    ln_d = np.log(species_disks(scene_of({**LOGNORMAL, "count": n}))[0][0])
    assert abs(ln_d.mean() - math.log(median)) < 4 * sigma / math.sqrt(n)
    assert abs(ln_d.std(ddof=1) - sigma) < 4 * sigma / math.sqrt(2 * (n - 1))


@pytest.mark.parametrize("shape", [UNIFORM, LOGNORMAL,
                                   {**LOGNORMAL, "diameter_min": 7e-3, "diameter_max": 9e-3}])
def test_the_mean_disk_area_is_that_of_the_draws(shape):
    """Species.mean_area (the volume_fraction's count): the analytic E[pi d^2/4] against the
    mean of 2000 drawn disks, within 4 standard errors; a truncated log-normal's draws stay in
    its window."""
    scene = scene_of({**shape, "count": 2000})
    d = species_disks(scene)[0][0]
    area = math.pi * d**2 / 4
    assert abs(area.mean() - scene.species[0].mean_area()) < 4 * area.std() / math.sqrt(d.size)
    assert d.min() >= shape.get("diameter_min", 0.0)
    assert d.max() <= shape.get("diameter_max", math.inf)


def test_each_disks_mass_is_its_density_times_its_volume():
    """In the run's particle arrays: m = rho pi (d/2)^2 h for every free disk, and the
    diameters are the drawn ones."""
    scene = scene_of({**UNIFORM, "count": 40}, {**LOGNORMAL, "count": 10},
                     geometry=SMALL_CELL)
    sim = Simulation(scene)
    got = sim.gathered("radius", "mass", "kind")
    free = got["kind"] == 0
    r, m = got["radius"][free], got["mass"][free]
    np.testing.assert_allclose(m, RHO * math.pi * r**2 * H, rtol=1e-12, atol=0.0)
    drawn = np.concatenate([d for d, _ in species_disks(scene)])
    np.testing.assert_array_equal(np.sort(2 * r), np.sort(drawn))
    assert np.unique(r).size == 50


def test_the_seed_decides_the_disks():
    """The same scene gives the same disks (a second build, a round trip through its TOML
    file); another seed other ones; two species of one distribution differ (the species'
    index seeds too)."""
    rows = ({**UNIFORM, "count": 50}, {**UNIFORM, "count": 50})
    one, again, other = scene_of(*rows), scene_of(*rows), scene_of(*rows, seed=4)
    a, b, c = (species_disks(s) for s in (one, again, other))
    np.testing.assert_array_equal(a[0][0], b[0][0])
    np.testing.assert_array_equal(a[1][0], b[1][0])
    assert not np.any(a[0][0] == c[0][0])
    assert not np.any(a[0][0] == a[1][0])


def test_a_distribution_round_trips_and_a_fixed_species_keeps_its_table(tmp_path):
    scene = scene_of({**LOGNORMAL, "diameter_max": 9e-3, "count": 30})
    write_scene(scene, tmp_path / "s.toml")
    back = load_scene(tmp_path / "s.toml")
    assert back == scene and back.fingerprint() == scene.fingerprint()
    np.testing.assert_array_equal(species_disks(back)[0][0], species_disks(scene)[0][0])
    fixed = couette_scene(counts=(30, 5)).to_dict()["species"][0]
    assert set(fixed) == {"name", "diameter", "mass", "count"}
    assert Species is scene.species[0].__class__


def test_a_distribution_scene_runs_with_the_step_of_its_lightest_pair():
    """The damped spring's t_c = pi/omega_d, omega_d^2 = k_n/m_red - (gamma_n/2 m_red)^2, of
    the two smallest drawn disks (masses rho pi (d/2)^2 h from the run's radii), over
    dt_per_contact = 50 (shortened by at most 1 % to divide a power of ten of a second);
    then 300 steps stay finite with every disk between the rings."""
    scene = scene_of({**UNIFORM, "count": 60}, {**LOGNORMAL, "count": 15},
                     geometry=SMALL_CELL)
    sim = Simulation(scene)
    got = sim.gathered("radius", "kind")
    r = np.sort(got["radius"][got["kind"] == 0])[:2]
    m1, m2 = RHO * math.pi * r**2 * H
    m_red = m1 * m2 / (m1 + m2)
    t_c = math.pi / math.sqrt(K_N / m_red - (GAMMA_N / (2 * m_red)) ** 2)
    assert smallest_contact_time(scene) == pytest.approx(t_c, rel=1e-12)
    assert t_c / 50 * 0.99 <= resolve_dt(scene) <= t_c / 50 * (1 + 1e-12)
    assert sim.dt == resolve_dt(scene)
    sim.advance_steps(300)
    p = sim.gathered("position", "kind")
    x = p["position"][p["kind"] == 0]
    assert np.all(np.isfinite(x))
    rad = np.hypot(x[:, 0], x[:, 1])
    assert rad.min() > SMALL_CELL["inner_radius"] and rad.max() < SMALL_CELL["outer_start_radius"]


def test_the_volume_fraction_fills_with_the_mean_disk_area():
    """volume_fraction = 0.4 with a uniform species: the count is the fraction's area over
    the mean disk area, so the drawn disks reach 0.4 within the sampling error of their
    summed area (4 standard errors)."""
    shape = {**UNIFORM, "share": 1.0}
    scene = scene_of(shape, geometry={**SMALL_CELL, "volume_fraction": 0.4})
    d = species_disks(scene)[0][0]
    g = scene.geometry
    area = math.pi * (g.outer_radius**2 - g.inner_radius**2)
    se = math.sqrt(d.size) * np.std(math.pi * d**2 / 4) / area  # of the summed disk area
    assert abs(volume_fraction(scene) - 0.4) < 4 * se + 1 / d.size


def test_the_density_warning_reads_a_distributions_density():
    same = scene_of({**UNIFORM, "count": 30}, {"diameter": 8e-3, "count": 5})
    assert density_warning(same) is None
    heavy = scene_of({**UNIFORM, "count": 30}, {"diameter": 8e-3, "count": 5,
                                                 "density": 10 * RHO})
    assert "density 1060 kg/m^3, uniform diameters" in density_warning(heavy)


BAD = [
    ({**UNIFORM, "mass": 2.7e-4, "count": 5},
     "[[species]] #0 mass = 0.00027: not with diameter_distribution = 'uniform'"),
    ({**UNIFORM, "diameter_min": 9e-3, "diameter_max": 6e-3, "count": 5},
     "[[species]] #0 diameter_max = 0.006: must be > diameter_min = 0.009"),
    ({**UNIFORM, "diameter_max": 6e-3, "count": 5},
     "[[species]] #0 diameter_max = 0.006: must be > diameter_min = 0.006"),
    ({**LOGNORMAL, "diameter_sigma": 0.0, "count": 5},
     "[[species]] #0 diameter_sigma = 0.0: must be > 0"),
    ({**LOGNORMAL, "diameter_sigma": -0.2, "count": 5},
     "[[species]] #0 diameter_sigma = -0.2: must be > 0"),
    ({**UNIFORM, "diameter_distribution": "normal", "count": 5},
     "[[species]] #0 diameter_distribution = 'normal': must be one of 'fixed', 'uniform', "
     "'lognormal'"),
    ({"diameter_distribution": "uniform", "diameter_min": 6e-3, "count": 5},
     "[[species]] #0 diameter_max: missing (required with diameter_distribution = 'uniform'"),
    ({"diameter_distribution": "lognormal", "diameter_median": 7e-3, "count": 5},
     "[[species]] #0 diameter_sigma: missing (required with diameter_distribution = "
     "'lognormal'"),
    ({"count": 5}, "[[species]] #0 diameter: missing (give diameter in m, or a "
                   "diameter_distribution"),
    ({**UNIFORM, "diameter": 7e-3, "count": 5},
     "[[species]] #0 diameter = 0.007: not with diameter_distribution = 'uniform'"),
    ({**UNIFORM, "diameter_median": 7e-3, "count": 5},
     "[[species]] #0 diameter_median = 0.007: not with diameter_distribution = 'uniform'"),
    ({"diameter": 7e-3, "diameter_min": 6e-3, "count": 5},
     "[[species]] #0 diameter_min = 0.006: not with diameter_distribution = 'fixed'"),
    ({**LOGNORMAL, "diameter_min": 0.02, "count": 5},
     "[[species]] #0 diameter_min = 0.02: the window [0.02, inf] m holds"),
    ({**LOGNORMAL, "density": "auto", "count": 5},
     "[[species]] #0 density: missing (required with a diameter_distribution"),
]


@pytest.mark.parametrize("row, message", BAD)
def test_bad_distributions_are_refused_naming_key_and_value(row, message):
    with pytest.raises(SceneError) as e:
        scene_of(row)
    assert message in str(e.value)


def test_a_lognormal_tail_wider_than_the_gap_is_refused():
    """Untruncated, the largest drawn disk must still fit across the annulus gap."""
    with pytest.raises(SceneError) as e:
        scene_of({**LOGNORMAL, "diameter_median": 0.03, "diameter_sigma": 0.5, "count": 5},
                 geometry=SMALL_CELL)
    assert "gap must be larger than the largest drawn diameter" in str(e.value)


def test_the_tutorials_distribution_example_is_a_valid_scene():
    """docs/tutorial.md's example in examples/small_dense.toml's cell: it fills the cell to
    0.816 within the sampling error of the drawn disks' area (4 standard errors), and its
    disks can be placed."""
    import re
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    text = (root / "docs" / "tutorial.md").read_text().split("### A continuous size")[1]
    example = tomllib.loads(re.search(r"```toml\n(.*?)```", text, re.S).group(1))
    d = tomllib.loads((root / "examples" / "small_dense.toml").read_text())
    d["geometry"].update(example["geometry"])
    d["species"] = example["species"]
    scene = scene_from_dict(d)
    disks = species_disks(scene)[0][0]
    g = scene.geometry
    se = math.sqrt(disks.size) * np.std(math.pi * disks**2 / 4) / (
        math.pi * (g.outer_radius**2 - g.inner_radius**2))
    assert abs(volume_fraction(scene) - 0.816) < 4 * se + 1 / disks.size
    assert initial_configuration(scene).n_free == disks.size  # the disks fit at the start

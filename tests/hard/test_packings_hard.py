"""Hard Couette cases: the densest packing of the paper and beyond, and the inner ring stopped,
reversed and driven 100x faster (or refused where the contact law cannot follow)."""

import numpy as np
import pytest
from helpers import couette_scene

from averaging.report import global_volume_fraction
from pardem.input.scene import SceneError
from pardem.simulation import Simulation
from pardem.core.timestep import MAX_IMPACT_OVERLAP, resolve_dt

SMALL_CELL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
              "compression_time": 0.1}


def compress_and_relax(counts, t_relax: float):
    """The paper's cell compressed in 2 s with the inner ring at rest, then left alone: returns
    the scene, the largest overlap / d seen, and kinetic energies (J) sampled every 0.25 s."""
    scene = couette_scene(counts=counts, geometry={"omega_inner": 0.0})
    sim = Simulation(scene)
    overlap, energy = 0.0, []
    for k in range(1, int(round((2.0 + t_relax) / 0.05)) + 1):  # every 0.05 s
        sim.run(end=0.05 * k, progress=False)
        overlap = max(overlap, sim.max_overlap())
        if k % 5 == 0:
            energy.append(sim.kinetic_energy())
    s = sim.gathered("position", "velocity")
    assert np.all(np.isfinite(s["position"])) and np.all(np.isfinite(s["velocity"]))
    r = np.hypot(*s["position"][: sim.n_free].T)
    assert r.min() > 0.1035 and r.max() < 0.2525  # nobody escaped
    return scene, overlap, np.array(energy), sim


@pytest.mark.parametrize("counts,nu_bar", [((2555, 399), 0.8194), ((2620, 409), 0.840)])
def test_densest_packings_compress_boundedly_and_relax(counts, nu_bar):
    """Simulation C (v-bar = 0.8194) and a denser cell (v-bar = 0.840): the compression stays
    bounded (largest overlap reported) and the packing relaxes and stays relaxed: the kinetic
    energy falls by orders of magnitude after the outer ring stops and never comes back."""
    scene, overlap, energy, sim = compress_and_relax(counts, t_relax=2.0)
    assert global_volume_fraction(scene) == pytest.approx(nu_bar, abs=1e-3)
    print(f"\nv-bar {global_volume_fraction(scene):.4f}: largest overlap during and after the "
          f"compression {100 * overlap:.2f} % of d; E_kin at 2 s {energy[7]:.3g} J, at 4 s "
          f"{energy[-1]:.3g} J")
    assert overlap < 0.10
    peak = energy[:8].max()  # during the compression
    assert energy[-1] < 1e-3 * peak
    assert np.all(energy[10:] < 1e-2 * peak)  # stays low after the first 0.5 s of relaxation


@pytest.mark.parametrize("omega", [0.0, -0.1, 10.0])
def test_inner_ring_stopped_reversed_and_100x_faster(omega):
    """The inner ring at rest, turning clockwise, and 100x the paper's speed: the run stays
    finite, nobody leaves the cell, overlaps stay below the bound the speed guard is built on
    (at 100x the sheared packing pushes against the fixed outer ring: ~13 % here), and a
    moving ring drags its first layer along in its own direction."""
    sim = Simulation(couette_scene(counts=(260, 40), geometry={**SMALL_CELL, "omega_inner": omega}))
    overlap = 0.0
    for k in range(1, 25):  # the largest overlap, sampled every 0.025 s
        sim.run(end=0.025 * k, progress=False)
        overlap = max(overlap, sim.max_overlap())
    s = sim.gathered("position", "velocity")
    xf, vf = s["position"][: sim.n_free], s["velocity"][: sim.n_free]
    assert np.all(np.isfinite(xf)) and np.all(np.isfinite(vf))
    r = np.hypot(*xf.T)
    assert r.min() > 0.05 and r.max() < 0.09
    print(f"\nomega_inner = {omega} rad/s: largest overlap {100 * overlap:.1f} % of d")
    assert overlap < MAX_IMPACT_OVERLAP  # what the speed guard promises
    near = r < 0.05 + 1.2 * 7.42e-3
    x, v = xf[near], vf[near]
    v_phi = np.mean((x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0]) / r[near])
    if omega == 0.0:
        assert abs(v_phi) < 1e-3
    else:
        assert np.sign(v_phi) == np.sign(omega)


def test_ring_too_fast_for_the_contact_law_is_refused():
    """1000x the paper's speed: a disk hit by the ring would overlap it by more than a diameter;
    the scene is refused with the key, the speed and the largest usable value. By hand: a disk
    hit at v overlaps by up to v sqrt(m/k_n); per own diameter the large disk is the worse,
    sqrt(0.490e-3/352.1)/8.99e-3 = 0.1312 s/m against 0.1191 for the small one, so 25 % is
    reached at v = 0.25/0.1312 = 1.905 m/s, omega = v/R_i = 18.41 rad/s."""
    scene = couette_scene(geometry={"omega_inner": 100.0})
    with pytest.raises(SceneError) as err:
        resolve_dt(scene)
    msg = str(err.value)
    assert msg.startswith(
        "[geometry] omega_inner = 100.0: the ring surface moves at up to 10.3 m/s")
    assert "|omega_inner| <= 18.4 rad/s" in msg  # 18.407 rounded down: it holds as printed
    assert resolve_dt(couette_scene(geometry={"omega_inner": 18.4})) > 0
    with pytest.raises(SceneError, match=r"compression_time = 0.0: the outer ring must move"):
        resolve_dt(couette_scene(geometry={"compression_time": 0.0}))
    with pytest.raises(SceneError, match=r"\[geometry\] compression_time = 0.005"):
        resolve_dt(couette_scene(geometry={"compression_time": 0.005}))
    assert resolve_dt(couette_scene(geometry={"omega_inner": -10.0})) > 0  # 100x is accepted


def test_rings_without_contacts_are_nan_marked_not_a_crash():
    """A dilute cell averaged in situ: rings whose fabric is singular (no contacts) give NaN
    for the elastic deformation gradient, the curvature and what is formed from them, and
    finite volume fraction and velocity; no warning, no exception."""
    scene = couette_scene(counts=(30, 0), geometry={**SMALL_CELL, "outer_start_radius": 0.09,
                                                    "compression_time": 0.0},
                          averaging={"start": 0.01, "end": 0.05, "sample_interval": 0.01})
    sim = Simulation(scene)
    sim.run(end=0.05, progress=False)
    f = sim.rings.fields()
    lonely = f["tr_F"] == 0
    assert lonely.sum() > 10
    for key in ("eps_rr", "kappa_zr", "stiffness", "mu_c", "angle_eps"):
        assert np.all(np.isnan(f[key][lonely])), key
    occupied = f["nu"] > 0
    assert np.all(np.isfinite(f["nu"])) and np.all(np.isfinite(f["v_phi"][occupied]))

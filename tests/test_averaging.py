"""Averaging: ring weights, signs of the contact sums, and the mean-field limit of a regular
compressed packing (SPEC §4)."""

import math

import numpy as np
import pytest

from averaging.sample import from_contacts
from averaging.fields import COL, N_COLUMNS
from averaging.sums import accumulate
from averaging.weights import EXACT, SLICE
from averaging.weights import weights_table

A_SMALL = 3.71e-3


def tanh_sinh(f, lo, hi, levels=7):
    """Double-exponential quadrature of f over [lo, hi]: converges to ~1e-15 even with the
    square-root endpoint singularities of a circle's chord length (independent of the code)."""
    h = 2.0 ** -levels
    t = np.arange(-6.0, 6.0 + h / 2, h)
    u = 0.5 * math.pi * np.sinh(t)
    x = np.tanh(u)
    w = 0.5 * math.pi * np.cosh(t) / np.cosh(u) ** 2
    keep = np.abs(x) < 1.0
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    return half * h * np.sum(w[keep] * f(mid + half * x[keep]))


def disk_area_between(rho, a, r_lo, r_hi):
    """Area of the disk (centre at distance rho, radius a) with r_lo <= r < r_hi, as the
    integral over r of the length of the circle of radius r inside the disk."""
    def arc(r):
        c = np.clip((rho**2 + r**2 - a**2) / (2 * rho * r), -1.0, 1.0)
        return 2.0 * r * np.arccos(c)

    lo, hi = max(r_lo, rho - a, 0.0), min(r_hi, rho + a)
    if hi <= lo:
        return 0.0
    cuts = sorted({lo, hi, *(c for c in (a - rho,) if lo < c < hi)})
    return sum(tanh_sinh(arc, p, q) for p, q in zip(cuts[:-1], cuts[1:]))


@pytest.mark.parametrize("weighting", ["slice", "exact", "centre", "gaussian"])
def test_each_particles_weights_sum_to_one(weighting):
    rng = np.random.default_rng(4)
    rho = rng.uniform(0.1, 0.25, 500)
    a = rng.choice([A_SMALL, 4.495e-3], 500)
    # rings from 0.1035 m: some particles reach past the first and the last ring
    w = weights_table(rho, a, 0.1035, A_SMALL / 4, 160, weighting)
    assert np.all(w >= 0.0)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=0, atol=1e-14)


def test_exact_weights_equal_numerical_integration():
    rng = np.random.default_rng(5)
    r0, dr, n = 0.1, A_SMALL / 4, 40
    worst = 0.0
    for _ in range(40):
        rho, a = rng.uniform(0.108, 0.128), rng.choice([A_SMALL, 4.495e-3])
        w = weights_table(np.array([rho]), np.array([a]), r0, dr, n, "exact")[0]
        ref = np.array([disk_area_between(rho, a, r0 + k * dr, r0 + (k + 1) * dr)
                        for k in range(n)]) / (math.pi * a * a)
        worst = max(worst, np.abs(w - ref).max())
    print(f"\nexact weights vs tanh-sinh integration: max difference {worst:.2e}")
    assert worst < 1e-10


def test_centre_and_gaussian_weights():
    """centre: all weight in the ring of the centre; gaussian: the normal distribution of width
    a/2 integrated over each ring (checked by quadrature of the density)."""
    r0, dr, n = 0.1, A_SMALL / 4, 40
    rho, a = 0.11234, A_SMALL
    w = weights_table(np.array([rho]), np.array([a]), r0, dr, n, "centre")[0]
    k = int((rho - r0) // dr)
    assert w[k] == 1.0 and w.sum() == 1.0
    w = weights_table(np.array([rho]), np.array([a]), r0, dr, n, "gaussian")[0]
    sigma = a / 2

    def pdf(r):
        return np.exp(-0.5 * ((r - rho) / sigma) ** 2) / (sigma * math.sqrt(2 * math.pi))

    ref = np.array([tanh_sinh(pdf, r0 + j * dr, r0 + (j + 1) * dr) for j in range(n)])
    # the kernel is cut at 4 sigma, the tails folded into the outermost rings it reaches: that
    # moves at most the tail mass Phi(-4) = 3.17e-5 (quadrature here, not the code's erfc)
    tail = tanh_sinh(pdf, rho - 12 * sigma, rho - 4 * sigma)
    assert tail == pytest.approx(3.167e-5, rel=1e-3)
    np.testing.assert_allclose(w, ref, rtol=0, atol=tail * 1.001)
    inner = np.abs(np.arange(n) * dr + r0 + dr / 2 - rho) < 3 * sigma  # well inside the cut
    np.testing.assert_allclose(w[inner], ref[inner], rtol=0, atol=1e-12)
    assert np.count_nonzero(w) == int(np.ceil(8 * sigma / dr)) + 1


def test_slice_deviates_from_exact_by_order_a_over_r():
    """Straight-line slicing misses the curvature of the ring edges: the area between a chord
    and an arc of radius r over a chord of length ~2a is ~a^3/r, i.e. a relative O(a/r)."""
    a, dr = A_SMALL, A_SMALL / 4
    devs = []
    for rho0 in (0.05, 0.1, 0.2, 0.4, 0.8):
        rho = rho0 + np.linspace(0.0, dr, 41)
        args = (rho, np.full(rho.size, a), rho0 - 0.02, dr, 60)
        devs.append(np.abs(weights_table(*args, "slice") - weights_table(*args, "exact")).max())
        print(f"r = {rho0:4.2f} m, a/r = {a / rho0:.4f}: max |w_slice - w_exact| = {devs[-1]:.2e}")
    ratios = np.array(devs[:-1]) / np.array(devs[1:])
    assert np.all(np.abs(ratios - 2.0) < 0.05)  # halves when r doubles: first order in a/r
    assert devs[1] < 0.01  # at the paper's inner ring the bias stays below 1 % of a weight


def hex_packing(a, delta, r_lo, r_hi):
    """Disks of radius a on a triangular lattice of spacing 2a - delta inside an annulus,
    every lattice neighbour a contact of overlap delta (n from the partner to the particle,
    force k_n delta n, no tangential spring)."""
    s = 2 * a - delta
    m = int(r_hi / s) + 2
    i, j = np.meshgrid(np.arange(-m, m + 1), np.arange(-m, m + 1))
    x = np.column_stack([(i + 0.5 * j).ravel() * s, (j * math.sqrt(3) / 2).ravel() * s])
    x = x + np.array([0.31, 0.17]) * s  # no particle on the axis
    r = np.hypot(x[:, 0], x[:, 1])
    x = x[(r > r_lo) & (r < r_hi)]
    d = x[:, None, :] - x[None, :, :]
    dist = np.hypot(d[..., 0], d[..., 1])
    p, q = np.nonzero((dist < 1.01 * s) & (dist > 0))
    n = d[p, q] / dist[p, q, None]
    return x, p, n


def hex_ring_sums(a, delta, h, k_n, r0, dr, exact):
    """Ring sums of the compressed triangular packing between 0.1 and 0.16 m."""
    x, p, n = hex_packing(a, delta, 0.1, 0.16)
    cnt = x.shape[0]
    smp = from_contacts(x, np.zeros_like(x), np.zeros(cnt), np.full(cnt, a), np.ones(cnt),
                        p, n, np.full(p.size, delta), k_n * delta * n, np.zeros((p.size, 2)))
    s = np.zeros((int(0.06 / dr), N_COLUMNS))
    accumulate(smp.particles, smp.contacts, (h, r0, dr, EXACT if exact else SLICE), s)
    return s


def test_regular_packing_gives_the_mean_field_result():
    """Every contact has the same overlap delta and lever a - delta/2, so per particle
    -Sum f (x) l = k_n delta (a - delta/2) Sum n (x) n exactly; hence in every ring
    sigma = k'_n delta (1 - delta/2a) F / (pi a) and eps = delta (1 - delta/2a) / a I, i.e.
    the paper's sigma = k'_n delta F/(pi a), eps = (delta/a) I up to the lever's delta/2a,
    and tr F = nu C identically. The only other error is round-off."""
    a, delta, h, k_n = A_SMALL, 2e-5, 6e-3, 352.1
    r0, dr = 0.1, a / 4
    s = hex_ring_sums(a, delta, h, k_n, r0, dr, exact=True)
    n_rings = s.shape[0]
    ring_vol = 2 * math.pi * h * (r0 + (np.arange(n_rings) + 0.5) * dr) * dr

    def tensor(name):
        t = np.array([[s[:, COL[f"{name}_rr"]], s[:, COL[f"{name}_rphi"]]],
                      [s[:, COL[f"{name}_phir"]], s[:, COL[f"{name}_phiphi"]]]])
        return np.moveaxis(t, -1, 0)  # [ring, 2, 2]

    inside = s[:, COL["vol"]] > 0.5 * ring_vol  # rings well inside the packing
    assert inside.sum() > 50
    fabric = tensor("fabric")[inside] / ring_vol[inside, None, None]
    sigma = tensor("stress")[inside] / ring_vol[inside, None, None]
    deform = tensor("deform")[inside] * math.pi * h / ring_vol[inside, None, None]
    lever = 1 - delta / (2 * a)
    np.testing.assert_allclose(sigma, (k_n / h) * delta * lever / (math.pi * a) * fabric,
                               rtol=1e-12, atol=1e-12 * np.abs(sigma).max())
    eps = deform @ np.linalg.inv(fabric)
    np.testing.assert_allclose(eps, np.broadcast_to(delta * lever / a * np.eye(2), eps.shape),
                               rtol=0, atol=1e-12 * delta / a)
    assert np.all(np.trace(sigma, axis1=1, axis2=2) > 0)  # compression positive
    nu = s[inside, COL["vol"]] / ring_vol[inside]
    coord = s[inside, COL["coord"]] / s[inside, COL["vol"]]
    np.testing.assert_allclose(np.trace(fabric, axis1=1, axis2=2), nu * coord, rtol=1e-12)
    # equal disks: contacts per particle (number-weighted) = the volume-weighted mean
    per_particle = s[inside, COL["contacts"]] / s[inside, COL["count"]]
    np.testing.assert_allclose(per_particle, coord, rtol=1e-12)
    # the bulk of the packing: 6 contacts, nu of the triangular lattice
    bulk = np.abs(coord - 6) < 1e-9
    assert bulk.sum() > 30
    nu_hex = math.pi * a**2 / (math.sqrt(3) / 2 * (2 * a - delta) ** 2)
    assert np.abs(nu[bulk] / nu_hex - 1).max() < 0.05  # a ring is ~a/4 wide: lattice texture


def test_two_contact_case_by_hand():
    """One particle at (0.1, 0) m (e_r = x, e_phi = y), alone in one ring (weight 1):
    contact 1 with a partner further out (n = -e_r, overlap d1, spring xi1 along e_phi),
    contact 2 with a partner behind it in phi (n = +e_phi, overlap d2, no spring)."""
    a, h, k_n, k_t = 4e-3, 6e-3, 352.1, 267.1
    d1, d2, xi1 = 1e-4, 5e-5, 2e-5
    normal = np.array([[-1.0, 0.0], [0.0, 1.0]])
    spring = np.array([[0.0, xi1], [0.0, 0.0]])
    force = k_n * np.array([d1, d2])[:, None] * normal - k_t * spring
    smp = from_contacts(np.array([[0.1, 0.0]]), np.array([[0.0, 0.02]]), np.array([0.5]),
                        np.array([a]), np.array([1.0]), np.array([0, 0]), normal,
                        np.array([d1, d2]), force, spring)
    s = np.zeros((1, N_COLUMNS))
    accumulate(smp.particles, smp.contacts, (h, 0.05, 0.1, EXACT), s)
    s = dict(zip(COL, s[0]))
    l1, l2 = a - d1 / 2, a - d2 / 2  # lever lengths; l1 = +l1 e_r, l2 = -l2 e_phi
    ft = -k_t * xi1  # tangential force of contact 1, along e_phi
    vol = math.pi * a * a * h
    expected = {
        "vol": vol, "count": 1.0, "mom_phi": vol * 0.02, "mom_r": 0.0, "spin": vol * 0.5,
        "coord": 2 * vol, "fabric_rr": vol, "fabric_phiphi": vol, "fabric_rphi": 0.0,
        # -f (x) l: contact 1 f = (-k_n d1, ft), l = (l1, 0);
        # contact 2 f = (0, k_n d2), l = (0, -l2)
        "stress_rr": k_n * d1 * l1, "stress_phir": -ft * l1, "stress_rphi": 0.0,
        "stress_phiphi": k_n * d2 * l2,
        # Delta = d n - xi: contact 1 (-d1, -xi1), contact 2 (0, d2)
        "deform_rr": d1 * l1, "deform_phir": xi1 * l1, "deform_phiphi": d2 * l2,
        # l x f = l_r f_phi - l_phi f_r: contact 1: l1 ft; contact 2: 0
        "couple_r": -(l1 * ft) * l1, "couple_phi": 0.0,
        "curv_r": -(l1 * -xi1) * l1, "curv_phi": 0.0,
    }
    for key, value in expected.items():
        assert s[key] == pytest.approx(value, rel=1e-12, abs=1e-30), key
    assert s["stress_rr"] + s["stress_phiphi"] > 0 and s["deform_rr"] + s["deform_phiphi"] > 0
    # sticking spring: couple stress and curvature have the same sign (mu_c > 0)
    assert s["couple_r"] * s["curv_r"] > 0


def test_ring_without_contacts_gives_nan_strain_not_a_crash():
    """A ring whose particles touch nothing has a singular fabric: eps and kappa are NaN there
    (never a crash, never a silent zero); nu and the velocities stay finite."""
    from averaging.fields import derived

    a, h = A_SMALL, 6e-3
    x = np.array([[0.1, 0.0], [0.0, 0.13]])
    smp = from_contacts(x, np.array([[0.0, 0.01], [0.0, 0.0]]), np.zeros(2), np.full(2, a),
                        np.ones(2), np.array([1, 1]), np.array([[0.0, -1.0], [1.0, 0.0]]),
                        np.full(2, 1e-5), np.zeros((2, 2)), np.zeros((2, 2)))
    s = np.zeros((12, N_COLUMNS))
    accumulate(smp.particles, smp.contacts, (h, 0.095, 0.0035, SLICE), s)
    r = 0.095 + (np.arange(12) + 0.5) * 0.0035
    f = derived(s, r, 0.0035, h)
    lonely = s[:, COL["vol"]] > 0
    lonely &= s[:, COL["coord"]] == 0  # rings holding only the particle without contacts
    assert lonely.any()
    assert np.all(np.isnan(f["eps_rr"][lonely])) and np.all(np.isnan(f["kappa_zr"][lonely]))
    assert np.all(np.isfinite(f["nu"][lonely])) and np.all(np.isfinite(f["v_phi"][lonely]))


def test_in_situ_and_offline_averaging_agree(tmp_path):
    """The same run averaged while it runs and afterwards from its snapshots (pardem average)."""
    from helpers import couette_scene

    from averaging.io import read_rings
    from pardem.cli import main
    from pardem.input.scene_file import write_scene

    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 3.0}
    scene = couette_scene(counts=(260, 40), geometry=g, output={"snapshot_interval": 0.05},
                          averaging={"start": 0.15, "end": 0.3, "sample_interval": 0.05,
                                     "weighting": "exact"})
    write_scene(scene, tmp_path / "s.toml")
    run = tmp_path / "run"
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(run), "--quiet"]) == 0
    assert main(["average", str(run)]) == 0
    live, offline = read_rings(run), read_rings(run / "offline")
    assert live["sums"].shape == offline["sums"].shape and live["sums"].shape[0] == 4
    np.testing.assert_array_equal(live["times"], offline["times"])
    scale = np.abs(live["sums"]).max(axis=(0, 1))
    assert np.all(np.abs(live["sums"] - offline["sums"]) <= 1e-12 * scale)
    assert np.abs(live["sums"][:, :, COL["curv_r"]]).max() > 0  # springs and wall contacts in
    # loads on the rings: in situ from the contact tables, offline from the snapshot's, each
    # contact's share added correctly rounded: the same bits
    np.testing.assert_array_equal(live["ring_loads_samples"], offline["ring_loads_samples"])
    np.testing.assert_array_equal(live["inner_torque_samples"], offline["inner_torque_samples"])
    assert np.all(live["inner_torque_samples"] > 0)


def test_derived_quantities_on_known_fields():
    from averaging.derived import eigen, exponential_fit
    from averaging.fields import derived

    c, s_ = math.cos(math.radians(30)), math.sin(math.radians(30))
    rot = np.array([[c, -s_], [s_, c]])
    t = rot @ np.diag([3.0, 1.0]) @ rot.T
    tr, dev, angle = eigen(t[None])
    assert tr[0] == pytest.approx(4.0) and dev[0] == pytest.approx(2.0)
    assert angle[0] == pytest.approx(30.0)
    rt = np.linspace(0, 12, 60)
    v0, s = exponential_fit(rt, 0.7 * np.exp(-rt / 1.6))
    assert v0 == pytest.approx(0.7, rel=1e-12) and s == pytest.approx(1.6, rel=1e-12)
    # rigid rotation v_phi = Omega r: no shear (D = 0), W = Omega, no excess spin if omega = W
    r = np.linspace(0.1, 0.2, 50)
    sums = np.zeros((50, N_COLUMNS))
    sums[:, COL["vol"]] = 1.0
    sums[:, COL["mom_phi"]] = 0.3 * r
    sums[:, COL["spin"]] = 0.3
    f = derived(sums, r, 0.002, 6e-3)
    np.testing.assert_allclose(f["D_rphi"], 0.0, atol=1e-12)
    np.testing.assert_allclose(f["W_rphi"], 0.3, rtol=1e-12)
    np.testing.assert_allclose(f["excess_spin"], 0.0, atol=1e-12)


def test_mean_field_stiffness_equals_trace_of_fabric():
    """Paper eq.: in the mean field 2 pi E / k'_n = tr F (exactly, for equal overlaps)."""
    from averaging.fields import derived

    a, delta, h, k_n = A_SMALL, 2e-5, 6e-3, 352.1
    r0, dr = 0.1, a / 4
    s = hex_ring_sums(a, delta, h, k_n, r0, dr, exact=False)
    r = r0 + (np.arange(s.shape[0]) + 0.5) * dr
    f = derived(s, r, dr, h, (r - r0) / (2 * a), k_n / h, 1.0)
    inside = f["nu"] > 0.5
    np.testing.assert_allclose(f["stiffness"][inside], f["tr_F"][inside], rtol=1e-12)


def test_default_ring_width_follows_the_smallest_diameter():
    """[averaging] ring_width = "auto" (the default): d_small/8, the paper's choice, for any
    particle size (a cell of 2 mm disks gets 0.25 mm rings, not the paper's 0.93 mm)."""
    from helpers import couette_scene

    from pardem.sampling import ring_width
    from pardem.input.schema import scene_from_dict

    scene = couette_scene(averaging={"start": 0.0, "end": 1.0})
    assert scene.averaging.ring_width is None
    assert ring_width(scene) == 7.42e-3 / 8
    small = scene_from_dict({**scene.to_dict(), "species": [
        {"name": "s", "diameter": 2e-3, "mass": 1e-5, "count": 10},
        {"name": "l", "diameter": 3e-3, "mass": 2e-5, "count": 10}]})
    assert ring_width(small) == 2e-3 / 8


def test_sample_steps_stop_at_the_runs_last_step():
    """An [averaging] end far past the run (1e12 s) allocates nothing beyond the run: with
    dt = 1e-4 s and samples every 0.05 s (500 steps), from 0.1 s (step 1000) to the run's last
    step 2600, the samples are steps 1000, 1500, 2000, 2500."""
    from pardem.output.writers import sample_steps

    got = sample_steps(0.1, 1e12, 0.05, 1e-4, last_step=2600)
    assert got.tolist() == [1000, 1500, 2000, 2500]
    assert sample_steps(0.1, 0.2, 0.05, 1e-4, last_step=10**12).tolist() == [1000, 1500, 2000]
    assert sample_steps(0.1, math.inf, 0.05, 1e-4, last_step=2600).size == 0

"""The flow-regime fields: the kinetic (streaming) stress, the inertial number, psi_6.

Expectations are independent of the averaging code: the covariance of prescribed velocities
(numpy), the analytic strain rate of a prescribed flow, and lattices of known order.
"""

import math

import numpy as np
import pytest

from averaging.fields import COL, N_COLUMNS, derived
from averaging.order import psi6
from averaging.sample import from_contacts
from averaging.timeavg import RingAverager

R0, A, M, H = 0.2, 0.004, 3e-4, 6e-3  # radius of the gas ring, disk radius, mass, height


def _gas(v_polar: np.ndarray) -> "Sample":  # noqa: F821
    """Non-touching disks at radius R0, evenly spaced in angle, with polar velocities
    v_polar [n, 2] = (v_r, v_phi)."""
    n = len(v_polar)
    phi = 2 * math.pi * np.arange(n) / n
    er = np.column_stack([np.cos(phi), np.sin(phi)])
    ephi = np.column_stack([-er[:, 1], er[:, 0]])
    x = R0 * er
    v = v_polar[:, :1] * er + v_polar[:, 1:] * ephi
    none = np.zeros(0, np.int64)
    return from_contacts(x, v, np.zeros(n), np.full(n, A), np.full(n, M), none,
                         np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2)))


def test_kinetic_stress_of_a_dilute_gas_is_the_velocity_covariance():
    """20 disks on one circle (2 pi R0 / 20 = 63 mm apart: no contacts), 5 samples of
    prescribed velocities about a mean flow U e_phi. Every disk has the same ring weights, so
    the rings' sigma_kin V add up to m times the sum over disks of v'(x)v' per sample, v' the
    deviation from the mean over all samples and disks (numpy's covariance)."""
    rng = np.random.default_rng(7)
    u = np.array([0.0, 0.05])
    draws = [u + rng.normal(0, [0.01, 0.02], size=(20, 2)) for _ in range(5)]
    avg = RingAverager(R0 - 0.01, R0 + 0.01, A / 4, "slice", H, 8e-3, 352.1, 1.0)
    for k, vel in enumerate(draws):
        avg.add(_gas(vel), float(k))
    f = avg.fields()
    all_v = np.concatenate(draws)
    cov = np.cov(all_v.T, bias=True)  # population covariance over samples x disks
    expected = M * len(draws[0]) * cov  # per sample: sum over the 20 disks
    vol = 2 * math.pi * H * f["r"] * avg.dr
    for a, b, name in ((0, 0, "rr"), (0, 1, "rphi"), (1, 1, "phiphi")):
        got = np.nansum(f[f"sigma_kin_{name}"] * vol)
        assert got == pytest.approx(expected[a, b], rel=1e-9, abs=1e-15), name
    assert np.allclose(f["sigma_kin_rphi"], f["sigma_kin_phir"], equal_nan=True)
    # compression positive: the streaming stress adds to the pressure, never subtracts
    assert np.all(f["pressure_kin"][np.isfinite(f["pressure_kin"])] >= 0)
    assert np.nansum(f["pressure_kin"] * vol) == pytest.approx(0.5 * np.trace(expected))
    assert np.all(np.nan_to_num(f["pressure"]) == 0)  # no contacts


def test_a_gas_in_rigid_motion_has_no_kinetic_stress():
    """All disks at the same polar velocity in every sample: no fluctuation about the flow."""
    avg = RingAverager(R0 - 0.01, R0 + 0.01, A / 4, "slice", H, 8e-3, 352.1, 1.0)
    for k in range(3):
        avg.add(_gas(np.tile([0.0, 0.03], (12, 1))), float(k))
    f = avg.fields()
    scale = M * 0.03**2 / (2 * math.pi * H * R0 * A)
    for name in ("rr", "rphi", "phiphi"):
        assert np.nanmax(np.abs(f[f"sigma_kin_{name}"])) < 1e-12 * scale


def _sums(r, v_phi, pressure, pressure_kin, rho, d):
    """Ring sums of rings at radii r (width dr) whose fields are the given profiles: one disk
    per ring (count 1, volume V^p = m / rho), contact stress p I, kinetic stress p_kin I."""
    dr = r[1] - r[0]
    vol_ring = 2 * math.pi * H * r * dr
    s = np.zeros((r.size, N_COLUMNS))
    vp = math.pi * (d / 2) ** 2 * H
    s[:, COL["vol"]], s[:, COL["count"]], s[:, COL["mass"]] = vp, 1.0, rho * vp
    s[:, COL["diam"]] = d
    s[:, COL["mom_phi"]] = vp * v_phi
    s[:, COL["stress_rr"]] = s[:, COL["stress_phiphi"]] = pressure * vol_ring
    s[:, COL["mmom_phi"]] = rho * vp * v_phi
    # kinetic: (kin_rr - 0)/V = p_kin and (kin_phiphi - m v_phi^2)/V = p_kin
    s[:, COL["kin_rr"]] = pressure_kin * vol_ring
    s[:, COL["kin_phiphi"]] = pressure_kin * vol_ring + rho * vp * v_phi**2
    return s, dr


def test_inertial_number_of_a_prescribed_flow():
    """v_phi = P + Q r^2: D_rphi = (dv/dr - v/r)/2 = (Q r - P/r)/2 analytically; I = 2|D_rphi| d sqrt(rho/p) with p = p_contact + p_kin. np.gradient is exact
    for a quadratic away from the two end rings, which are left out."""
    r = np.linspace(0.11, 0.2, 40)
    big_p, q, p_c, p_k, rho, d = 0.01, 2.0, 3.0, 0.5, 1060.0, 7.42e-3
    v = big_p + q * r**2
    s, dr = _sums(r, v, p_c, p_k, rho, d)
    f = derived(s, r, dr, H)
    gamma = np.abs(q * r - big_p / r)
    expected = gamma * d * np.sqrt(rho / (p_c + p_k))
    assert np.allclose(f["pressure"], p_c) and np.allclose(f["pressure_kin"], p_k)
    assert np.allclose(f["inertial_number"][1:-1], expected[1:-1], rtol=1e-9)


def test_rigid_rotation_has_inertial_number_zero():
    r = np.linspace(0.11, 0.2, 30)
    s, dr = _sums(r, 0.1 * r, 2.0, 0.0, 1060.0, 7.42e-3)
    assert np.allclose(derived(s, r, dr, H)["inertial_number"][1:-1], 0.0, atol=1e-12)


def test_a_ring_without_pressure_has_no_inertial_number():
    """Sheared (v_phi/r varies) but without contacts or fluctuations: p = 0, I undefined."""
    r = np.linspace(0.11, 0.2, 10)
    s, dr = _sums(r, np.full(r.size, 0.5), 0.0, 0.0, 1060.0, 7.42e-3)
    assert np.all(np.isnan(derived(s, r, dr, H)["inertial_number"]))


def _lattice(kind: str, n: int = 12, d: float = 1.0) -> np.ndarray:
    i, j = np.meshgrid(np.arange(n), np.arange(n))
    if kind == "triangular":
        return np.column_stack([(i + 0.5 * (j % 2)).ravel() * d,
                                (j * math.sqrt(3) / 2).ravel() * d])
    return np.column_stack([i.ravel() * d, j.ravel() * d])


def test_psi6_of_lattices():
    """Triangular lattice: 1 for every disk (6 neighbours at 60 degrees, also at the edges,
    where the present bonds still lie at multiples of 60 degrees); square lattice: 0 inside
    (4 bonds at multiples of 90 degrees cancel: 1 - 1 + 1 - 1); random gas: small."""
    tri = psi6(_lattice("triangular"), 1.0)
    assert np.allclose(tri, 1.0)
    sq = _lattice("square")
    value = psi6(sq, 1.0)
    inside = (sq[:, 0] > 0) & (sq[:, 0] < 11) & (sq[:, 1] > 0) & (sq[:, 1] < 11)
    assert np.allclose(value[inside], 0.0, atol=1e-12)
    rng = np.random.default_rng(3)
    gas = rng.uniform(0, 40, size=(1200, 2))
    g = psi6(gas, 1.0)
    assert 0.2 < np.nanmean(g) < 0.8  # random bonds: about 1/sqrt(neighbours), not ordered
    assert np.nanmean(g) < np.mean(tri) - 0.3
    isolated = psi6(np.array([[0.0, 0.0], [10.0, 0.0]]), 1.0)
    assert np.all(np.isnan(isolated))

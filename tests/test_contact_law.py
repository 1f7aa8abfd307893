"""Kernel tests of the contact law against hand computations (jitted and pure Python)."""

import math

import numpy as np
import pytest

from pardem.contact import LawOptions, make_contact_law, make_pair_force
from pardem.state import Params

PRM = Params(dt=1e-4, k_n=352.1, gamma_n=0.19, k_t=267.1, mu=0.44, mu_b_g=0.0, r_in=0.0,
             omega_in=0.0, r_out=0.0, r_out0=0.0, t_comp=0.0, skin=1e-3, escape_radius=math.inf)
FULL = LawOptions(damping=True, friction=True, clip=False)

# Hand computation (SPEC §3): a_i = a_j = 5 mm, r_i - r_j = (9 mm, 0) so n = (1, 0), delta = 1 mm;
# v_i - v_j = (-0.1, 0.2) m/s, w_i = 2, w_j = 4 rad/s -> s = a_i w_i + a_j w_j = 0.03 m/s,
# v_ij = (-0.1, 0.2) - 0.03 (0, 1) = (-0.1, 0.17); delta_dot = 0.1 m/s;
# f_n = 352.1 * 1e-3 + 0.19 * 0.1 = 0.3711 N; v_t = (0, 0.17), xi = v_t dt = (0, 1.7e-5) m;
# f_t = -k_t xi = (0, -4.5407e-3) N < mu f_n = 0.163284 N (sticks);
# torque on i: l_i = -(a - delta/2) n = (-4.5e-3, 0): tau_i = l_x f_y = 2.043315e-5 N m = tau_j.
HAND = dict(fx=0.3711, fy=-4.5407e-3, tau=2.043315e-5, xi=(0.0, 1.7e-5))


@pytest.mark.parametrize("jitted", [True, False])
def test_pair_force_matches_hand_computation(jitted):
    pair = make_pair_force(FULL)
    fn = pair if jitted else pair.py_func
    touching, fx, fy, ti, tj, xix, xiy = fn(9e-3, 0.0, 5e-3, 5e-3, -0.1, 0.2, 2.0, 4.0, 0.0, 0.0,
                                            0.0, PRM)
    assert touching
    assert fx == pytest.approx(HAND["fx"], rel=1e-12)
    assert fy == pytest.approx(HAND["fy"], rel=1e-12)
    assert ti == pytest.approx(HAND["tau"], rel=1e-12)
    assert tj == pytest.approx(HAND["tau"], rel=1e-12)
    assert (xix, xiy) == pytest.approx(HAND["xi"], rel=1e-12, abs=1e-20)


def test_sliding_contact_is_capped_at_coulomb():
    law = make_contact_law(FULL)
    # same geometry as the hand case, but a spring pre-loaded far beyond the Coulomb cap
    fn, ftx, fty, xix, xiy, sliding = law(1.0, 0.0, 1e-3, -0.1, 0.17, 0.0, 0.01, PRM)
    assert sliding
    assert math.hypot(ftx, fty) == pytest.approx(0.44 * abs(fn), rel=1e-14)
    assert PRM.k_t * math.hypot(xix, xiy) == pytest.approx(0.44 * abs(fn), rel=1e-14)
    assert fty < 0  # opposes the stretched spring


def test_sticking_contact_stays_below_cap():
    law = make_contact_law(FULL)
    fn, ftx, fty, xix, xiy, sliding = law(1.0, 0.0, 1e-3, -0.1, 0.17, 0.0, 1e-4, PRM)
    assert not sliding
    assert PRM.k_t * math.hypot(xix, xiy) < 0.44 * abs(fn)
    assert xiy == pytest.approx(1e-4 + 0.17 * PRM.dt, rel=1e-14)


def test_spring_is_projected_into_the_tangent_plane():
    law = make_contact_law(FULL)
    # a spring with a normal component (the contact rotated): only its tangential part survives
    _, _, _, xix, xiy, _ = law(1.0, 0.0, 1e-3, 0.0, 0.0, 3e-5, 2e-5, PRM)
    assert xix == 0.0 and xiy == 2e-5


def test_swapping_i_and_j_negates_the_force_bitwise():
    pair = make_pair_force(FULL)
    rng = np.random.default_rng(7)
    for _ in range(2000):
        dx, dy = rng.normal(0, 4e-3, 2)
        ai, aj = rng.uniform(3e-3, 5e-3, 2)
        dvx, dvy = rng.normal(0, 0.1, 2)
        wi, wj = rng.normal(0, 10, 2)
        xix, xiy = rng.normal(0, 1e-4, 2)
        a = pair(dx, dy, ai, aj, dvx, dvy, wi, wj, xix, xiy, 1e-5, PRM)
        b = pair(-dx, -dy, aj, ai, -dvx, -dvy, wj, wi, -xix, -xiy, 1e-5, PRM)
        assert a[0] == b[0]
        np.testing.assert_array_equal(np.array([a[1], a[2], a[5], a[6]]),
                                      -np.array([b[1], b[2], b[5], b[6]]))
        assert a[3] == b[4] and a[4] == b[3]


def test_disabled_terms_vanish():
    plain = make_contact_law(LawOptions(damping=False, friction=False, clip=False))
    fn, ftx, fty, xix, xiy, _ = plain(1.0, 0.0, 1e-3, -0.1, 0.17, 0.0, 0.5, PRM)
    assert fn == pytest.approx(0.3521, rel=1e-14)
    assert (ftx, fty, xix, xiy) == (0.0, 0.0, 0.0, 0.5)
    clip = make_contact_law(LawOptions(damping=True, friction=False, clip=True))
    # separating fast: damping would make the force attractive; clipping sets it to zero
    assert clip(1.0, 0.0, 1e-5, 1.0, 0.0, 0.0, 0.0, PRM)[0] == 0.0


def test_damping_is_weighted_by_the_in_contact_fraction_of_the_step():
    """A contact that starts within the half step around a force sample gets the damping force
    for the in-contact fraction of the sample's window [t - dt/2, t + dt/2] only."""
    law = make_contact_law(LawOptions(damping=True, friction=True, clip=False))
    vn = -0.1  # approaching at 0.1 m/s: delta_dot = 0.1, overlap changes 5e-6 m per half step
    half = 0.1 * PRM.dt / 2
    full = PRM.gamma_n * 0.1
    assert law(1.0, 0.0, 2 * half, vn, 0.0, 0.0, 0.0, PRM)[0] == pytest.approx(
        PRM.k_n * 2 * half + full, rel=1e-14)  # deep enough: whole window
    assert law(1.0, 0.0, 0.0, vn, 0.0, 0.0, 0.0, PRM)[0] == pytest.approx(0.5 * full, rel=1e-14)
    # touches a quarter of a step after the sample: in contact for the last quarter of the window
    fn, ftx, fty, xix, xiy, _ = law(1.0, 0.0, -0.5 * half, vn, 0.3, 0.0, 0.0, PRM)
    assert fn == pytest.approx(0.25 * full, rel=1e-12)
    assert (ftx, fty, xix, xiy) == (0.0, 0.0, 0.0, 0.0)  # no spring before touching
    assert law(1.0, 0.0, -1.01 * half, vn, 0.0, 0.0, 0.0, PRM)[0] == 0.0

"""Kernel tests of the contact law against hand computations (jitted and pure Python)."""

import math

import numpy as np
import pytest

from pardem.contact import contact_law, pair_force
from pardem.state import Params
from pardem.stepper import BATCH

PRM = Params(dt=1e-4, k_n=352.1, gamma_n=0.19, k_t=267.1, mu=0.44, mu_b_g=0.0, r_in=0.0,
             omega_in=0.0, r_out=0.0, r_out0=0.0, t_comp=0.0, skin=1e-3, escape_radius=math.inf)
FULL = (True, True, False, True)  # damping, friction, clip, window


def make_law(flags=FULL, jitted=True):
    fn = contact_law if jitted else contact_law.py_func
    return lambda *args: fn(*args, *flags)


def make_pair(flags=FULL, jitted=True):
    fn = pair_force if jitted else pair_force.py_func
    return lambda *args: fn(*args, *flags)

# Hand computation (SPEC §3): a_i = a_j = 5 mm, r_i - r_j = (9 mm, 0) so n = (1, 0), delta = 1 mm;
# v_i - v_j = (-0.1, 0.2) m/s, w_i = 2, w_j = 4 rad/s -> s = a_i w_i + a_j w_j = 0.03 m/s,
# v_ij = (-0.1, 0.2) - 0.03 (0, 1) = (-0.1, 0.17); delta_dot = 0.1 m/s;
# f_n = 352.1 * 1e-3 + 0.19 * 0.1 = 0.3711 N; v_t = (0, 0.17), xi = v_t dt = (0, 1.7e-5) m;
# f_t = -k_t xi = (0, -4.5407e-3) N < mu f_n = 0.163284 N (sticks);
# torque on i: l_i = -(a - delta/2) n = (-4.5e-3, 0): tau_i = l_x f_y = 2.043315e-5 N m = tau_j.
HAND = dict(fx=0.3711, fy=-4.5407e-3, tau=2.043315e-5, xi=(0.0, 1.7e-5))


@pytest.mark.parametrize("jitted", [True, False])
def test_pair_force_matches_hand_computation(jitted):
    fn = make_pair(jitted=jitted)
    touching, fx, fy, ti, tj, xix, xiy, sliding = fn(9e-3, 0.0, 5e-3, 5e-3, -0.1, 0.2, 2.0, 4.0,
                                                     0.0, 0.0, 0.0, PRM)
    assert touching and not sliding
    assert fx == pytest.approx(HAND["fx"], rel=1e-12)
    assert fy == pytest.approx(HAND["fy"], rel=1e-12)
    assert ti == pytest.approx(HAND["tau"], rel=1e-12)
    assert tj == pytest.approx(HAND["tau"], rel=1e-12)
    assert (xix, xiy) == pytest.approx(HAND["xi"], rel=1e-12, abs=1e-20)


def test_sliding_contact_is_capped_at_coulomb():
    law = make_law()
    # same geometry as the hand case, but a spring pre-loaded far beyond the Coulomb cap
    fn, ftx, fty, xix, xiy, sliding = law(1.0, 0.0, 1e-3, -0.1, 0.17, 0.0, 0.01, PRM)
    assert sliding
    assert math.hypot(ftx, fty) == pytest.approx(0.44 * abs(fn), rel=1e-14)
    assert PRM.k_t * math.hypot(xix, xiy) == pytest.approx(0.44 * abs(fn), rel=1e-14)
    assert fty < 0  # opposes the stretched spring


def test_sticking_contact_stays_below_cap():
    law = make_law()
    fn, ftx, fty, xix, xiy, sliding = law(1.0, 0.0, 1e-3, -0.1, 0.17, 0.0, 1e-4, PRM)
    assert not sliding
    assert PRM.k_t * math.hypot(xix, xiy) < 0.44 * abs(fn)
    assert xiy == pytest.approx(1e-4 + 0.17 * PRM.dt, rel=1e-14)


def test_spring_is_projected_into_the_tangent_plane():
    law = make_law()
    # a spring with a normal component (the contact rotated): only its tangential part survives
    _, _, _, xix, xiy, _ = law(1.0, 0.0, 1e-3, 0.0, 0.0, 3e-5, 2e-5, PRM)
    assert xix == 0.0 and xiy == 2e-5


def test_swapping_i_and_j_negates_the_force_bitwise():
    pair = make_pair()
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
    plain = make_law((False, False, False, True))
    fn, ftx, fty, xix, xiy, _ = plain(1.0, 0.0, 1e-3, -0.1, 0.17, 0.0, 0.5, PRM)
    assert fn == pytest.approx(0.3521, rel=1e-14)
    assert (ftx, fty, xix, xiy) == (0.0, 0.0, 0.0, 0.5)
    clip = make_law((True, False, True, True))
    # separating fast: damping would make the force attractive; clipping sets it to zero
    assert clip(1.0, 0.0, 1e-5, 1.0, 0.0, 0.0, 0.0, PRM)[0] == 0.0


def test_damping_is_weighted_by_the_in_contact_fraction_of_the_step():
    """A contact that starts within the half step around a force sample gets the damping force
    for the in-contact fraction of the sample's window [t - dt/2, t + dt/2] only."""
    law = make_law()
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


@pytest.mark.parametrize("friction", [True, False])
def test_compiled_force_loop_equals_sum_of_kernel_calls(friction):
    """The batched pair loop gives the same bits as summing standalone kernel calls in pair order
    (guards against compiler inlining and the SIMD law with deferred branches changing
    results)."""
    from helpers import dense_packing, free_scene

    from pardem.simulation import Simulation

    eff = {"normal_damping": True, "rotation": True, "tangential_friction": friction}
    sim = Simulation(free_scene(dense_packing(10, 10, speed=0.05), effects=eff,
                                contact={"mu": 0.02}))
    sim.advance_steps(200)
    ps, pr = sim.ps, sim.pairs
    xi0 = pr.xi.copy()
    sim._compute_forces()
    f = np.zeros_like(ps.f)
    tau = np.zeros_like(ps.tau)
    xi = np.zeros((pr.count[0], 2))
    n_sliding = 0
    for k in range(pr.count[0]):
        i, j = pr.i[k], pr.j[k]
        xix, xiy = (xi0[k] if friction else (0.0, 0.0))
        r = pair_force(ps.x[i, 0] - ps.x[j, 0], ps.x[i, 1] - ps.x[j, 1], ps.radius[i],
                       ps.radius[j], ps.v_pred[i, 0] - ps.v_pred[j, 0],
                       ps.v_pred[i, 1] - ps.v_pred[j, 1], ps.w_pred[i], ps.w_pred[j], xix, xiy,
                       sim.clock.reach[0], sim.prm, True, friction, False, True)
        xi[k] = r[5:7]
        n_sliding += r[7]
        if r[0]:
            f[i] += r[1:3]
            f[j] -= r[1:3]
            tau[i] += r[3]
            tau[j] += r[4]
    # several batches, the last one partial
    assert pr.count[0] > 2 * BATCH and pr.count[0] % BATCH
    if friction:  # the loop's deferred branch, recomputed pair by pair, is exercised
        assert n_sliding > 0
    np.testing.assert_array_equal(ps.f, f)
    np.testing.assert_array_equal(ps.tau, tau)
    if friction:
        np.testing.assert_array_equal(pr.xi[:pr.count[0]], xi)
    else:  # a frictionless scene stores no springs
        assert pr.xi.size == 0 and not xi.any()


@pytest.mark.parametrize("jitted", [True, False])
def test_deferred_law_is_exact_or_asks_for_a_redo(jitted):
    """The batched loop computes every pair with the rare branches deferred and redoes the
    flagged ones. That is exact only if an unflagged result has the same bits as the full law,
    and every contact that slides or is within half a step of touching is flagged."""
    pair = pair_force if jitted else pair_force.py_func
    rng = np.random.default_rng(11)
    flagged = {"sliding": 0, "window": 0, "plain": 0}
    for _ in range(3000):
        ai, aj = rng.uniform(3e-3, 5e-3, 2)
        dist = (ai + aj) * rng.uniform(0.97, 1.01)
        phi = rng.uniform(0, 2 * math.pi)
        dx, dy = dist * math.cos(phi), dist * math.sin(phi)
        dvx, dvy = rng.normal(0, 0.3, 2)
        wi, wj = rng.normal(0, 30, 2)
        xix, xiy = rng.normal(0, 2e-4, 2)
        args = (dx, dy, ai, aj, dvx, dvy, wi, wj, xix, xiy, 2e-4, PRM, *FULL)
        full, deferred = pair(*args, False), pair(*args, True)
        # the window is partial while the overlap is below half a step's change of it
        nx, ny = dx / dist, dy / dist
        s = ai * wi + aj * wj
        vn = (dvx + s * ny) * nx + (dvy - s * nx) * ny
        window = full[0] and ai + aj - dist < 0.5 * abs(vn) * PRM.dt
        assert deferred[0] == full[0]
        if full[7] or window:
            assert deferred[7]
            flagged["sliding" if full[7] else "window"] += 1
        else:
            assert not deferred[7]
            bits = [np.array(r[1:7]).view(np.int64) for r in (deferred, full)]
            np.testing.assert_array_equal(*bits)
            flagged["plain"] += full[0]
    assert min(flagged.values()) > 100, flagged

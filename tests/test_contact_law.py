"""Kernel tests of the contact law (contact.model, contact.laws) against hand computations,
jitted and pure Python."""

import math

import numpy as np
import pytest

from pardem.contact.lanes import BATCH
from pardem.contact.model import ContactOptions, LawParams, contact_law, pair_force
from pardem.core.forces import RECHECK, contact_forces, new_work

LAW = LawParams(dt=1e-4, k_n=352.1, gamma_n=0.19, k_t=267.1, mu=0.44, gamma_t=0.05, k_r=100.0,
                mu_r=0.1)
FULL = ContactOptions(damping=True, friction=True, clip=False, window=True)


def law(n, delta, v, spring, opts=FULL, jitted=True, xr=0.0, a_red=0.0, w=(0.0, 0.0)):
    """contact_law -> (fn, ftx, fty, fr, xix, xiy, xr, sliding)."""
    fn = contact_law if jitted else contact_law.py_func
    f, h = fn(n, delta, v, spring, xr, 0.0, a_red, w, LAW, opts)
    return f.fn, f.ftx, f.fty, f.fr, h.xix, h.xiy, h.xr, f.sliding  # hn: none for the linear law


def pair(d, a, dv, w, spring, reach=0.0, opts=FULL, jitted=True, xr=0.0):
    """pair_force -> (active, fx, fy, tau_i, tau_j, fn, ftx, fty, xix, xiy, xr, sliding)."""
    fn = pair_force if jitted else pair_force.py_func
    p, f, h = fn(d, a, dv, w, spring, xr, 0.0, reach, LAW, opts)
    return (p.active, p.fx, p.fy, p.tau_i, p.tau_j, f.fn, f.ftx, f.fty, h.xix, h.xiy, h.xr,
            f.sliding)  # hn: none for the linear law


# Hand computation (SPEC §3): a_i = a_j = 5 mm, r_i - r_j = (9 mm, 0) so n = (1, 0), delta = 1 mm;
# v_i - v_j = (-0.1, 0.2) m/s, w_i = 2, w_j = 4 rad/s -> s = a_i w_i + a_j w_j = 0.03 m/s,
# v_ij = (-0.1, 0.2) - 0.03 (0, 1) = (-0.1, 0.17); delta_dot = 0.1 m/s;
# f_n = 352.1 * 1e-3 + 0.19 * 0.1 = 0.3711 N; v_t = (0, 0.17), xi = v_t dt = (0, 1.7e-5) m;
# f_t = -k_t xi = (0, -4.5407e-3) N < mu f_n = 0.163284 N (sticks);
# torque on i: l_i = -(a - delta/2) n = (-4.5e-3, 0): tau_i = l_x f_y = 2.043315e-5 N m = tau_j.
HAND = dict(fx=0.3711, fy=-4.5407e-3, tau=2.043315e-5, xi=(0.0, 1.7e-5))
HAND_ARGS = ((9e-3, 0.0), (5e-3, 5e-3), (-0.1, 0.2), (2.0, 4.0), (0.0, 0.0))


@pytest.mark.parametrize("jitted", [True, False])
def test_pair_force_matches_hand_computation(jitted):
    r = pair(*HAND_ARGS, jitted=jitted)
    touching, fx, fy, ti, tj, fn, ftx, fty, xix, xiy, _, sliding = r
    assert touching and not sliding
    assert fx == pytest.approx(HAND["fx"], rel=1e-12)
    assert fy == pytest.approx(HAND["fy"], rel=1e-12)
    assert (fn, ftx, fty) == pytest.approx((HAND["fx"], 0.0, HAND["fy"]), rel=1e-12, abs=1e-20)
    assert ti == pytest.approx(HAND["tau"], rel=1e-12)
    assert tj == pytest.approx(HAND["tau"], rel=1e-12)
    assert (xix, xiy) == pytest.approx(HAND["xi"], rel=1e-12, abs=1e-20)


def test_sliding_contact_is_capped_at_coulomb():
    # same geometry as the hand case, but a spring pre-loaded far beyond the Coulomb cap
    fn, ftx, fty, _, xix, xiy, _, sliding = law((1.0, 0.0), 1e-3, (-0.1, 0.17), (0.0, 0.01))
    assert sliding
    assert math.hypot(ftx, fty) == pytest.approx(0.44 * abs(fn), rel=1e-14)
    assert LAW.k_t * math.hypot(xix, xiy) == pytest.approx(0.44 * abs(fn), rel=1e-14)
    assert fty < 0  # opposes the stretched spring


def test_sticking_contact_stays_below_cap():
    fn, ftx, fty, _, xix, xiy, _, sliding = law((1.0, 0.0), 1e-3, (-0.1, 0.17), (0.0, 1e-4))
    assert not sliding
    assert LAW.k_t * math.hypot(xix, xiy) < 0.44 * abs(fn)
    assert xiy == pytest.approx(1e-4 + 0.17 * LAW.dt, rel=1e-14)


def test_spring_is_projected_into_the_tangent_plane():
    # a spring with a normal component (the contact rotated): only its tangential part survives
    r = law((1.0, 0.0), 1e-3, (0.0, 0.0), (3e-5, 2e-5))
    assert r[4] == 0.0 and r[5] == 2e-5


def test_tangential_damping_adds_a_viscous_force_and_the_cap_keeps_its_share():
    """Trial force -k_t xi - gamma_t v_t; at the cap the spring holds k_t xi = -(f_t +
    gamma_t v_t) (Luding's rule), so the elastic part alone never exceeds what the cap left."""
    opts = FULL._replace(tangential_damping=True)
    fn, ftx, fty, _, xix, xiy, _, sliding = law((1.0, 0.0), 1e-3, (-0.1, 0.17), (0.0, 1e-4),
                                                opts)
    assert not sliding
    xi_new = 1e-4 + 0.17 * LAW.dt
    assert fty == pytest.approx(-LAW.k_t * xi_new - LAW.gamma_t * 0.17, rel=1e-14)
    assert ftx == 0.0 and xiy == pytest.approx(xi_new, rel=1e-14)
    fn, ftx, fty, _, xix, xiy, _, sliding = law((1.0, 0.0), 1e-3, (-0.1, 0.17), (0.0, 0.01),
                                                opts)
    assert sliding and math.hypot(ftx, fty) == pytest.approx(0.44 * abs(fn), rel=1e-14)
    assert LAW.k_t * xiy == pytest.approx(-(fty + LAW.gamma_t * 0.17), rel=1e-14)


def test_rolling_spring_follows_the_relative_rotation_and_its_limit():
    """xi_r += a' (w_i - w_j) dt; f_r = -k_r xi_r while |f_r| <= mu_r |f_n|, else capped there
    with the spring rescaled; the torques on i and j are a' f_r and -a' f_r."""
    opts = FULL._replace(rolling=True)
    a_red = 2.5e-3  # two 5 mm disks
    fn, _, _, fr, _, _, xr, sliding = law((1.0, 0.0), 1e-3, (0.0, 0.0), (0.0, 0.0), opts,
                                          xr=1e-6, a_red=a_red, w=(3.0, -1.0))
    assert xr == pytest.approx(1e-6 + a_red * 4.0 * LAW.dt, rel=1e-14)
    assert fr == pytest.approx(-LAW.k_r * xr, rel=1e-14) and not sliding
    fn, _, _, fr, _, _, xr, _ = law((1.0, 0.0), 1e-3, (0.0, 0.0), (0.0, 0.0), opts, xr=1e-3,
                                    a_red=a_red, w=(3.0, -1.0))
    assert fr == pytest.approx(-LAW.mu_r * fn, rel=1e-14)
    assert LAW.k_r * xr == pytest.approx(LAW.mu_r * fn, rel=1e-14)
    r = pair((9e-3, 0.0), (5e-3, 5e-3), (0.0, 0.0), (3.0, -1.0), (0.0, 0.0), opts=opts,
             xr=1e-6)
    plain = pair((9e-3, 0.0), (5e-3, 5e-3), (0.0, 0.0), (3.0, -1.0), (0.0, 0.0))
    fr = -LAW.k_r * r[10]
    assert r[3] - plain[3] == pytest.approx(a_red * fr, rel=1e-9)
    assert r[4] - plain[4] == pytest.approx(-a_red * fr, rel=1e-9)
    assert r[1:3] == plain[1:3]  # no force on the centres


@pytest.mark.parametrize("opts", [FULL, FULL._replace(tangential_damping=True, rolling=True)])
def test_swapping_i_and_j_negates_the_force_bitwise(opts):
    rng = np.random.default_rng(7)
    for _ in range(2000):
        dx, dy = rng.normal(0, 4e-3, 2)
        ai, aj = rng.uniform(3e-3, 5e-3, 2)
        dvx, dvy = rng.normal(0, 0.1, 2)
        wi, wj = rng.normal(0, 10, 2)
        xix, xiy = rng.normal(0, 1e-4, 2)
        xr = rng.normal(0, 1e-5)
        a = pair((dx, dy), (ai, aj), (dvx, dvy), (wi, wj), (xix, xiy), 1e-5, opts, xr=xr)
        b = pair((-dx, -dy), (aj, ai), (-dvx, -dvy), (wj, wi), (-xix, -xiy), 1e-5, opts,
                 xr=-xr)
        assert a[0] == b[0]
        np.testing.assert_array_equal(np.array([a[1], a[2], a[6], a[7], a[8], a[9], a[10]]),
                                      -np.array([b[1], b[2], b[6], b[7], b[8], b[9], b[10]]))
        assert a[5] == b[5] and a[3] == b[4] and a[4] == b[3]


def test_disabled_terms_vanish():
    plain = FULL._replace(damping=False, friction=False)
    fn, ftx, fty, fr, xix, xiy, _, _ = law((1.0, 0.0), 1e-3, (-0.1, 0.17), (0.0, 0.5), plain)
    assert fn == pytest.approx(0.3521, rel=1e-14)
    assert (ftx, fty, fr, xix, xiy) == (0.0, 0.0, 0.0, 0.0, 0.5)
    clip = FULL._replace(friction=False, clip=True)
    # separating fast: damping would make the force attractive; clipping sets it to zero
    assert law((1.0, 0.0), 1e-5, (1.0, 0.0), (0.0, 0.0), clip)[0] == 0.0


def test_damping_is_weighted_by_the_in_contact_fraction_of_the_step():
    """A contact that starts within the half step around a force sample gets the damping force
    for the in-contact fraction of the sample's window [t - dt/2, t + dt/2] only."""
    vn = -0.1  # approaching at 0.1 m/s: delta_dot = 0.1, overlap changes 5e-6 m per half step
    half = 0.1 * LAW.dt / 2
    full = LAW.gamma_n * 0.1
    assert law((1.0, 0.0), 2 * half, (vn, 0.0), (0.0, 0.0))[0] == pytest.approx(
        LAW.k_n * 2 * half + full, rel=1e-14)  # deep enough: whole window
    assert law((1.0, 0.0), 0.0, (vn, 0.0), (0.0, 0.0))[0] == pytest.approx(0.5 * full,
                                                                            rel=1e-14)
    # touches a quarter of a step after the sample: in contact for the last quarter of the window
    fn, ftx, fty, _, xix, xiy, _, _ = law((1.0, 0.0), -0.5 * half, (vn, 0.3), (0.0, 0.0))
    assert fn == pytest.approx(0.25 * full, rel=1e-12)
    assert (ftx, fty, xix, xiy) == (0.0, 0.0, 0.0, 0.0)  # no spring before touching
    assert law((1.0, 0.0), -1.01 * half, (vn, 0.0), (0.0, 0.0))[0] == 0.0


@pytest.mark.parametrize("friction", [True, False])
def test_compiled_force_loop_equals_sum_of_kernel_calls(friction):
    """The batched pair loop gives the same bits as summing standalone kernel calls in pair order
    (guards against compiler inlining and the SIMD law's selects changing results, and
    against the loop leaving out a pair that has a force), and records each pair's applied
    normal and tangential force."""
    from helpers import dense_packing, free_scene

    from pardem.simulation import Simulation

    eff = {"normal_damping": True, "rotation": True, "tangential_friction": friction}
    sim = Simulation(free_scene(dense_packing(10, 10, speed=0.05), effects=eff,
                                contact={"mu": 0.02}))
    sim.advance_steps(200)
    ps, pr = sim.ps, sim.pairs
    xi0 = pr.hist.copy()
    # three listed pairs that do not touch approach fast enough to touch within half a step:
    # the damping window gives them a share of the force before they touch
    count = int(pr.count[0])
    i, j = pr.i[:count], pr.j[:count]
    d = ps.x[i] - ps.x[j]
    gap = np.hypot(*d.T) - ps.radius[i] - ps.radius[j]
    for k in np.flatnonzero(gap > 0)[np.argsort(gap[gap > 0])][:3]:
        ps.v[i[k]] = ps.v[j[k]] - 4.0 * gap[k] / sim.prm.dt * d[k] / np.hypot(*d[k])
    sim.refresh()
    f = np.zeros_like(ps.f)
    tau = np.zeros_like(ps.tau)
    count = int(pr.count[0])
    xi, rec = np.zeros((count, 2)), np.zeros((count, 3))
    n_sliding = 0
    for k in range(count):
        i, j = pr.i[k], pr.j[k]
        spring = tuple(xi0[k]) if friction else (0.0, 0.0)
        p, c, h = pair_force((ps.x[i, 0] - ps.x[j, 0], ps.x[i, 1] - ps.x[j, 1]),
                       (ps.radius[i], ps.radius[j]),
                       (ps.v_pred[i, 0] - ps.v_pred[j, 0], ps.v_pred[i, 1] - ps.v_pred[j, 1]),
                       (ps.w_pred[i], ps.w_pred[j]), spring, 0.0, 0.0, sim.clock.reach[0],
                       sim.prm.law, sim.contact)
        xi[k] = h.xix, h.xiy
        rec[k] = c.fn, c.ftx, c.fty
        n_sliding += c.sliding
        if p.active:
            f[i] += (p.fx, p.fy)
            f[j] -= (p.fx, p.fy)
            tau[i] += p.tau_i
            tau[j] += p.tau_j
    # several batches, the last one partial
    assert count > 2 * BATCH and count % BATCH
    # the loop leaves out pairs farther apart than their own half step of approach; some of
    # those are within the law's reach test (all-zero results there), others get a share of
    # the damping before they touch
    i, j = pr.i[:count], pr.j[:count]
    dist = np.hypot(*(ps.x[i] - ps.x[j]).T)
    rs = ps.radius[i] + ps.radius[j]
    approach = 0.5 * sim.prm.law.dt * np.abs(ps.v_pred[i] - ps.v_pred[j]).sum(axis=1)
    left_out = dist >= rs + approach
    assert (left_out & (dist < rs + sim.clock.reach[0])).sum() > 0
    assert ((dist > rs) & ~left_out & (rec[:, 0] != 0)).sum() >= 3
    if friction:  # sliding contacts (the loop's Coulomb cap, with selects) are exercised
        assert n_sliding > 0
    # the step loop's call, then the loop called with the selection, without it, and without
    # it counting the pairs with a force (as it does every RECHECK calls)
    for fraction, calls in ((None, 0), (0.0, 0), (1.0, 0), (1.0, RECHECK)):
        if fraction is not None:
            work = new_work(sim.contact, count)
            work.rows[-1], work.rows[-2] = fraction, calls
            pr.hist[:count] = xi0[:count]
            pr.fn[:] = np.nan
            contact_forces(ps, pr, int(sim.clock.n_local[0]), sim.prm, sim.time,
                           sim.clock.reach[0], sim.contact, sim.options.rotation,
                           sim.options.walls, work, True)
            # both loops that count find the share of listed pairs with a normal force
            counted = fraction == 0.0 or calls == RECHECK
            assert work.rows[-1] == (np.count_nonzero(rec[:, 0]) / count if counted else fraction)
        np.testing.assert_array_equal(ps.f, f)
        np.testing.assert_array_equal(ps.tau, tau)
        np.testing.assert_array_equal(pr.fn[:count], rec[:, 0])
        np.testing.assert_array_equal(pr.ft[:count], rec[:, 1:])
        if friction:
            np.testing.assert_array_equal(pr.hist[:count], xi)
        else:  # a frictionless scene stores no springs
            assert pr.hist.size == 0 and not xi.any()


def test_compiled_law_with_selects_equals_python_arithmetic():
    """The compiled law computes the Coulomb cap and the damping window's in-contact fraction
    in every lane and selects (so that the batched loop stays vectorised, with no pair redone);
    its bits must equal plain Python's arithmetic of the same law for every kind of contact:
    sliding, within half a step of touching, and plain."""
    rng = np.random.default_rng(11)
    flagged = {"sliding": 0, "window": 0, "plain": 0}
    opts = FULL._replace(rolling=True, tangential_damping=True)
    for _ in range(3000):
        ai, aj = rng.uniform(3e-3, 5e-3, 2)
        dist = (ai + aj) * rng.uniform(0.97, 1.01)
        phi = rng.uniform(0, 2 * math.pi)
        dx, dy = dist * math.cos(phi), dist * math.sin(phi)
        dvx, dvy = rng.normal(0, 0.3, 2)
        wi, wj = rng.normal(0, 30, 2)
        xix, xiy = rng.normal(0, 2e-4, 2)
        xr = rng.normal(0, 1e-4)
        args = ((dx, dy), (ai, aj), (dvx, dvy), (wi, wj), (xix, xiy), 2e-4, opts)
        full = pair(*args, jitted=False, xr=xr)
        compiled = pair(*args, jitted=True, xr=xr)
        # the window is partial while the overlap is below half a step's change of it
        nx, ny = dx / dist, dy / dist
        s = ai * wi + aj * wj
        vn = (dvx + s * ny) * nx + (dvy - s * nx) * ny
        window = full[0] and ai + aj - dist < 0.5 * abs(vn) * LAW.dt
        assert compiled[0] == full[0] and compiled[11] == full[11]
        bits = [np.array(r[1:11]).view(np.int64) for r in (compiled, full)]
        np.testing.assert_array_equal(*bits)
        flagged["window" if window else "sliding" if full[11] else "plain"] += full[0]
    assert min(flagged.values()) > 100, flagged


def test_a_selection_zeroes_what_the_previous_one_left_as_a_call_that_zeroes_every_pair():
    """Between calls on one list, the selecting loop zeroes the stored history only of pairs
    it gave the law at its previous call and leaves out now, since every other pair already
    holds +0.0. While contacts open and close, forces, torques and histories must keep the
    bits of calls that zero every listed pair (the path without a previous selection, which
    test_compiled_force_loop_equals_sum_of_kernel_calls ties to the kernel)."""
    from helpers import dense_packing, free_scene

    from pardem.simulation import Simulation

    eff = {"normal_damping": True, "rotation": True, "tangential_friction": True}
    sim = Simulation(free_scene(dense_packing(10, 10, speed=0.05), effects=eff,
                                contact={"mu": 0.3}))
    sim.advance_steps(200)
    ps, sparse = sim.ps, sim.pairs
    count = int(sparse.count[0])
    full = sparse._replace(hist=sparse.hist.copy())
    works = {id(p): new_work(sim.contact, count) for p in (sparse, full)}
    rng = np.random.default_rng(5)
    args = (int(sim.clock.n_local[0]), sim.prm, sim.time, 0.0, sim.contact,
            sim.options.rotation, sim.options.walls)
    n = int(sim.clock.n_owned[0])
    left, opened = 0, 0
    for call in range(40):
        ps.x[:n] += rng.normal(0.0, 2e-3 * ps.radius[:n, None], (n, 2))
        before = sparse.hist[:count].copy()
        got = {}
        for p in (sparse, full):
            w = works[id(p)]
            w.rows[-1] = 0.0  # select, whatever the last call measured
            if p is full:
                w.n_live[0] = -1
            elif call:
                assert w.n_live[0] >= 0  # the previous selection is known
            contact_forces(ps, p, *args, w, False)
            got[id(p)] = (ps.f.copy(), ps.tau.copy(), p.hist[:count].copy())
        for a, b in zip(got[id(sparse)], got[id(full)]):
            np.testing.assert_array_equal(a.view(np.int64), b.view(np.int64))
        was_on = before.any(axis=1)
        now_on = sparse.hist[:count].any(axis=1)
        left += int((was_on & ~now_on).sum())
        opened += int((~was_on & now_on).sum())
    assert left > 20 and opened > 20, (left, opened)

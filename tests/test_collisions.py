"""Head-on collisions against the analytic damped-spring solution (SPEC §3), for disk-disk,
disk-flat-ring and disk-wall-disk contacts; the measured order of convergence in dt."""

import math

import numpy as np
import pytest
from helpers import (D_LARGE, D_SMALL, GAMMA_N, K_N, M_LARGE, M_SMALL, analytic_collision,
                     wall_setup)

from pardem.testing import measure, two_disks


PHASES = np.arange(8) / 8  # where, between two steps, the contact begins


def errors(d, m, dt, integrator="verlet"):
    """Relative errors of t_c and e_n for each entry phase."""
    tc, e = analytic_collision(m / 2)
    out = np.array([measure(*two_disks(d, m, dt, p, integrator, K_N, GAMMA_N))
                    for p in PHASES])
    return out[:, 0] / tc - 1, out[:, 1] / e - 1


@pytest.mark.parametrize("d,m,tc_spec,e_spec", [(D_SMALL, M_SMALL, 2.177e-3, 0.2223),
                                                (D_LARGE, M_LARGE, 2.769e-3, 0.3417)])
def test_head_on_converges_to_analytic(d, m, tc_spec, e_spec):
    tc, e = analytic_collision(m / 2)
    assert tc == pytest.approx(tc_spec, abs=0.5e-6) and e == pytest.approx(e_spec, abs=0.5e-4)
    sim = two_disks(d, m, "auto")[0]
    assert 0.99 * tc / 50 <= sim.dt <= tc / 50  # t_c/50, shortened to divide 10 ms
    et, ee = errors(d, m, "auto")  # default dt = t_c/50: within 5 % for every entry phase
    print(f"\n d = {d}: dt = t_c/50: max |err t_c| {abs(et).max():.2e}, max |err e_n| "
          f"{abs(ee).max():.2e}")
    assert abs(et).max() < 0.05 and abs(ee).max() < 0.05
    et, ee = errors(d, m, tc / 2000)  # fine dt: within 0.1 %
    print(f" dt = t_c/2000: max |err t_c| {abs(et).max():.2e}, max |err e_n| {abs(ee).max():.2e}")
    assert abs(et).max() < 1e-3 and abs(ee).max() < 1e-3


def test_order_of_convergence_in_dt():
    """Worst-phase errors at t_c/50 .. t_c/800. Measured here: t_c second order; e_n about first
    order (its error comes from the step in which the contact begins or ends)."""
    tc, _ = analytic_collision(M_SMALL / 2)
    rows = []
    for n in (50, 100, 200, 400, 800):
        et, ee = errors(D_SMALL, M_SMALL, tc / n)
        rows.append((n, abs(et).max(), abs(ee).max()))
    order_t = [math.log2(rows[k][1] / rows[k + 1][1]) for k in range(len(rows) - 1)]
    order_e = math.log2(rows[1][2] / rows[-1][2]) / (len(rows) - 2)
    print("\n dt=t_c/N  max err t_c  max err e_n")
    for n, et, ee in rows:
        print(f" {n:5d}  {et:9.2e}  {ee:9.2e}")
    print(" orders t_c:", np.round(order_t, 2), f" e_n (t_c/100 .. t_c/800): {order_e:.2f}")
    assert min(order_t) > 1.8
    assert order_e > 0.8


def test_halfstep_integrator_converges_to_analytic():
    """The alternative integrator ([time] integrator = "verlet-halfstep": half-step velocities
    in the damping and spring, no weighting at contact entry/exit) converges to the analytic
    collision too, its e_n at first order; docs/accuracy.md measures it against the default."""
    tc, e = analytic_collision(M_SMALL / 2)
    rows = [(n, *map(lambda a: abs(a).max(), errors(D_SMALL, M_SMALL, tc / n, "verlet-halfstep")))
            for n in (50, 400, 3200)]
    print("\n verlet-halfstep: dt=t_c/N  max err t_c  max err e_n")
    for n, et, ee in rows:
        print(f"  {n:5d}  {et:9.2e}  {ee:9.2e}")
    assert rows[-1][1] < 1e-3 and rows[-1][2] < 2e-3
    assert rows[1][2] < rows[0][2] / 4 and rows[2][2] < rows[1][2] / 4  # at least first order


@pytest.mark.parametrize("target", ["flat", "disk"])
def test_wall_collision_restitution_infinite_mass_partner(target):
    tc, e = analytic_collision(M_SMALL)  # m_red = m for an infinitely massive partner
    sim, ov, vr = wall_setup(target)
    assert 0.99 * tc / 50 <= sim.dt <= tc / 50  # one disk: the smallest pair is disk-wall
    tcm, em = measure(sim, ov, vr)
    assert abs(tcm / tc - 1) < 0.05 and abs(em / e - 1) < 0.05
    tcf, ef = measure(*wall_setup(target, dt=tc / 2000))
    assert abs(tcf / tc - 1) < 1e-3 and abs(ef / e - 1) < 1e-3

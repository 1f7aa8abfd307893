"""The bare loop of run_scripts/benchmarks/vs_bare_loop.py, the yardstick pardem's speed is
measured against, computes the same law: a head-on collision rebounds with the damped spring's
analytic restitution, and an oblique one conserves momentum and angular momentum while friction
turns the disks."""

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "run_scripts" / "benchmarks"))

from vs_bare_loop import bare_steps  # noqa: E402

from pardem.contact.damped_spring import contact_time, restitution  # noqa: E402

A, M, K_N, GAMMA_N, K_T, MU = 4e-3, 2.75e-4, 352.1, 0.19, 267.1, 0.44


def _two_disks(v0, b):
    """Two equal disks at rest apart, the first moving at v0 = (vx, vy) towards the second,
    offset by b across; steps of t_c/1000 until well after the contact."""
    m_red = 0.5 * M
    dt = contact_time(K_N, GAMMA_N, m_red) / 1000
    x = np.array([[-2.5 * A, b], [0.0, 0.0]])
    v = np.array([list(v0), [0.0, 0.0]])
    zeros = np.zeros(2)
    arrays = [x, v, zeros.copy(), np.zeros((2, 2)), zeros.copy(), np.full(2, A),
              np.full(2, 1.0 / M), np.full(2, 1.0 / (0.5 * M * A * A)), np.arange(2),
              np.array([0]), np.array([1]), np.zeros((1, 2))]
    law = (dt, K_N, GAMMA_N, K_T, MU, 0.0)
    steps = int((0.5 * A / abs(v0[0]) + 3 * contact_time(K_N, GAMMA_N, m_red)) / dt)
    bare_steps(*arrays, law, steps)
    return x, v, arrays[2]


def test_a_head_on_collision_rebounds_with_the_analytic_restitution():
    """Relative normal speed after / before = exp(-pi eta / omega), eta = gamma_n/(2 m_red);
    plain velocity Verlet (half-step velocities, no damping window) gives it an O(dt) error
    of up to ~6 % at dt = t_c/50 (SPEC §3), so ~0.3 % at t_c/1000."""
    _, v, w = _two_disks((0.1, 0.0), 0.0)
    e = (v[1, 0] - v[0, 0]) / 0.1
    assert math.isclose(e, restitution(K_N, GAMMA_N, 0.5 * M), rel_tol=0.005), e
    assert abs(v[0, 1]) + abs(v[1, 1]) + abs(w).sum() == 0.0
    assert math.isclose(v[0, 0] + v[1, 0], 0.1, rel_tol=1e-12)


def test_an_oblique_collision_conserves_momentum_and_turns_the_disks_alike():
    """Offset by half a radius: the tangential spring turns both disks the same way (the
    contact point's velocity is reduced), linear momentum is conserved to rounding, and so is
    angular momentum about the origin, spins included (I = m a^2/2)."""
    b = 0.5 * A
    x, v, w = _two_disks((0.1, 0.0), b)
    np.testing.assert_allclose(v.sum(axis=0), [0.1, 0.0], atol=1e-15)
    assert w[0] != 0.0 and math.isclose(w[0], w[1], rel_tol=1e-12)
    inertia = 0.5 * M * A * A
    l_orbit = M * (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0]).sum()
    l_start = M * (-b * 0.1)  # -(y v_x) of the first disk at the start
    assert math.isclose(l_orbit + inertia * w.sum(), l_start, rel_tol=1e-9)

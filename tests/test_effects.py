"""Only the effects a scene calls for: mu = 0 equals friction off; friction off stores no history
and costs less."""

import time

import numpy as np
from helpers import couette_scene, dense_packing, free_scene

from pardem.simulation import Simulation


def run(effects, contact=None, steps=3000):
    sim = Simulation(free_scene(dense_packing(10, 10, speed=0.05), effects=effects,
                                contact=contact))
    sim.advance_steps(steps)
    return sim


def test_mu_zero_equals_friction_off_bitwise():
    on = {"normal_damping": True, "rotation": True, "tangential_friction": True}
    a = run(on, contact={"mu": 0.0})
    b = run({**on, "tangential_friction": False})
    for name in ("x", "v", "omega", "theta", "f", "tau"):
        np.testing.assert_array_equal(getattr(a.ps, name), getattr(b.ps, name), err_msg=name)
    assert np.any(a.ps.x != Simulation(a.scene).ps.x)  # it did move


def test_frictionless_scene_stores_no_history():
    sim = run({"tangential_friction": False}, steps=10)
    assert sim.pairs.xi.shape == (0, 2) and sim.ps.xi_wall.shape == (0, 2)
    assert sim.pairs.count[0] > 0


def best_time(friction, steps=5_000, repeats=5):
    """Best wall time of ``steps`` steps of a dense, confined, sheared packing (300 disks in a
    small Couette cell, compressed first), so contacts persist while it is timed."""
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 1.0}
    sim = Simulation(couette_scene(counts=(260, 40), geometry=g,
                                   effects={"tangential_friction": friction}))
    sim.advance_steps(5_000)
    assert sim.contacts()["ids"].shape[0] > 300
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sim.advance_steps(steps)
        times.append(time.perf_counter() - t0)
    return min(times)


def test_friction_off_is_faster_than_friction_on():
    """Not a speed target, a structural check: compiling friction out removes work. The minimum
    of 5 runs is compared, with a margin, so machine noise does not decide it."""
    t_on = best_time(True)
    t_off = best_time(False)
    print(f"\n friction on {t_on:.4f} s, off {t_off:.4f} s per 5000 steps of 300 dense disks")
    assert t_off < 0.95 * t_on

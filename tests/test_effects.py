"""Only the effects a scene calls for: mu = 0 equals friction off; friction off stores no history.
What a disabled effect saves in time is measured by run_scripts/bench_effects.py (timings stay
out of the tests)."""

import numpy as np
from helpers import dense_packing, free_scene

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

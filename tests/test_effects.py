"""Only the effects a scene calls for: mu = 0 equals friction off; friction off stores no history.
What a disabled effect saves in time is measured by run_scripts/benchmarks/bench_effects.py
(timings stay out of the tests)."""

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
    sa, sb = a.gathered(), b.gathered()
    for name in ("position", "velocity", "omega", "theta", "force", "torque"):
        np.testing.assert_array_equal(sa[name], sb[name], err_msg=name)
    start = Simulation(a.scene).gathered("position")["position"]
    assert np.any(sa["position"] != start)  # it did move


def test_frictionless_scene_stores_no_history():
    sim = run({"tangential_friction": False}, steps=10)
    assert sim.history_columns == ()
    assert sim.pairs.hist.shape == (0, 2) and sim.ps.hist_wall.shape == (0, 2)  # no storage
    assert sim.contacts()["ids"].shape[0] > 0
    assert sim.checkpoint_state()[0]["pair_hist"].size == 0

"""The step loop's one pass over the particles (``integrate.kick_drift``): a step's closing kick
is deferred to the next step's pass while a call goes on, and applied alone at a call's last
step, so what a user sees at the end of any call is the finished step. The trajectory must not
depend on how a run is cut into calls: one call of N steps runs the fused pass N - 1 times,
calls of one step never do."""

from pathlib import Path

import numpy as np

from pardem.input.scene_file import load_scene
from pardem.simulation import Simulation

SCENE = Path(__file__).parent / "reference" / "fast_shear.toml"  # shear, rotation, bottom friction
STATE = ("x", "v", "omega", "theta", "f", "tau")


def _by_gid(sim) -> dict[str, np.ndarray]:
    n = int(sim.clock.n_owned[0])
    order = np.argsort(sim.ps.gid[:n])
    return {k: getattr(sim.ps, k)[:n][order].copy() for k in STATE}


def test_the_trajectory_does_not_depend_on_how_the_run_is_cut_into_calls():
    whole = Simulation(load_scene(SCENE))
    pieces = Simulation(load_scene(SCENE))
    for sim in (whole, pieces):
        sim.advance_steps(1500)  # compressed: most disks move
    calls = [1, 1, 2, 3, 1, 5, 8, 13, 1, 21, 34, 55, 89, 144, 2, 1, 119]
    whole.advance_steps(sum(calls))
    for n in calls:
        pieces.advance_steps(n)
        # a call ends with the closing kick: the velocities are the finished step's, the
        # same bits as those of a run stopped there in one call
    assert whole.step == pieces.step == 2000
    assert whole.n_rebuilds > 100  # builds fall inside calls of both runs
    a, b = _by_gid(whole), _by_gid(pieces)
    for k in STATE:
        assert np.array_equal(a[k], b[k]), k
    assert np.hypot(a["v"][:, 0], a["v"][:, 1]).min() > 0.0  # every disk moves


def test_one_step_is_velocity_verlet_with_bottom_friction_in_its_closing_kick():
    """Across one step between two calls: v(t + dt) = friction(v(t) + dt/2 f(t)/m + dt/2
    f(t + dt)/m), where bottom friction removes mu_b g dt of speed or stops the disk: the
    scheme's definition, whichever pass applied which kick."""
    sim = Simulation(load_scene(SCENE))
    sim.advance_steps(2000)  # compressed: every disk moves
    n = int(sim.clock.n_owned[0])
    v0, f0, inv_m, h = sim.ps.v[:n].copy(), sim.ps.f[:n].copy(), sim.ps.inv_mass[:n], 0.5 * sim.dt
    sim.advance_steps(1)
    free = v0 + h * f0 * inv_m[:, None] + h * sim.ps.f[:n] * inv_m[:, None]
    expected = np.maximum(np.hypot(free[:, 0], free[:, 1]) - sim.prm.mu_b_g * sim.dt, 0.0)
    got = np.hypot(sim.ps.v[:n, 0], sim.ps.v[:n, 1])
    assert (expected > 0.0).sum() > n // 2  # most disks move: the friction's branch is tested
    assert np.allclose(got, expected, rtol=1e-9, atol=1e-15)

"""Property-based: random small scenes (sizes, masses, speeds, spins, start overlaps within the
accepted 1 %, ring speeds within the accepted range) run for a few hundred steps without a NaN
or a particle leaving the cell. Effects come from two fixed sets (all on, all off) so that the
examples do not each compile a new kernel. A refused scene must name a known reason; it then
does not count as an example (``assume``), so Hypothesis's filter health check fails the test if
too few examples run, and explicit examples make sure each effect set runs at least once."""

import math

import numpy as np
from helpers import couette_scene, free_scene
from hypothesis import HealthCheck, assume, event, example, given, settings
from hypothesis import strategies as st

from pardem.input.scene import SceneError
from pardem.simulation import Simulation, SimulationError

ALL_ON = {"normal_damping": True, "tangential_friction": True, "rotation": True,
          "bottom_friction": True}
EFFECTS = st.sampled_from([ALL_ON, {}])  # {}: helpers.NO_EFFECTS for free scenes
# clear refusals a random scene may meet: a start overlap above 1 %, a contact overdamped
# for light disks (no contact time), too many disks for the cell, a ring too fast, a time step
# beyond the stiffest mode's limit (light disks, nearly overdamped: t_c/50 is long)
REFUSALS = ("overlap", "overdamped", "cannot place", "ring surface moves", "stability limit")
SETTINGS = settings(max_examples=25, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@st.composite
def free_particles(draw):
    """2-12 disks on a jittered grid; neighbours may start overlapping by up to 1 % of the
    smaller diameter (the loader's limit)."""
    n = draw(st.integers(2, 12))
    d = draw(st.lists(st.floats(2e-3, 1e-2), min_size=n, max_size=n))
    spacing = max(d) * draw(st.floats(0.99, 1.5))
    cols = math.ceil(math.sqrt(n))
    out = []
    for k in range(n):
        out.append({"x": (k % cols) * spacing, "y": (k // cols) * spacing,
                    # +-1 m/s a component: two disks meet at up to 2.8 m/s, mostly within
                    # the approach speed the law resolves (2.8 m/s for 2 mm against 1 cm)
                    "vx": draw(st.floats(-1.0, 1.0)), "vy": draw(st.floats(-1.0, 1.0)),
                    "omega": draw(st.floats(-50.0, 50.0)), "diameter": d[k],
                    "mass": 1060.0 * 6e-3 * math.pi * d[k] ** 2 / 4 * draw(st.floats(0.5, 2.0))})
    return out


def refused(e: SceneError) -> None:
    """A scene refused before the run, with a known reason: not an example."""
    reason = next((why for why in REFUSALS if why in str(e)), None)
    assert reason is not None, str(e)
    event(f"refused: {reason}")
    assume(False)


# two paper-sized disks closing at 0.2 m/s, 1 % apart
PAIR = [{"x": 0.0, "y": 0.0, "vx": 0.1, "vy": 0.0, "omega": 5.0, "diameter": 7.42e-3,
         "mass": 0.275e-3},
        {"x": 7.5e-3, "y": 0.0, "vx": -0.1, "vy": 0.01, "omega": 0.0, "diameter": 7.42e-3,
         "mass": 0.275e-3}]


@SETTINGS
@given(particles=free_particles(), effects=EFFECTS)
@example(particles=PAIR, effects=ALL_ON)
@example(particles=PAIR, effects={})
def test_random_free_scenes_stay_finite(particles, effects):
    try:
        sim = Simulation(free_scene(particles, effects=effects))
    except SceneError as e:
        refused(e)
    event("ran: all effects on" if effects else "ran: all effects off")
    s0 = sim.gathered("velocity", "mass")
    p0 = (s0["velocity"] * s0["mass"][:, None]).sum(axis=0)
    sim.advance_steps(300)
    s = sim.gathered("position", "velocity", "omega", "mass")
    assert np.all(np.isfinite(s["position"])) and np.all(np.isfinite(s["velocity"]))
    assert np.all(np.isfinite(s["omega"]))
    if not effects:  # no bottom friction: contacts conserve momentum
        mv = s["velocity"] * s["mass"][:, None]
        scale = np.abs(mv).sum() + 1e-30
        assert np.all(np.abs(mv.sum(axis=0) - p0) <= 1e-12 * scale)


@SETTINGS
@given(counts=st.tuples(st.integers(1, 250), st.integers(0, 40)),
       omega=st.floats(-20.0, 20.0), t_comp=st.floats(0.06, 0.3), seed=st.integers(0, 10**6),
       effects=st.sampled_from([{}, {"tangential_friction": False, "rotation": False}]))
@example(counts=(200, 20), omega=10.0, t_comp=0.1, seed=1, effects={})
def test_random_couette_cells_stay_finite_and_inside(counts, omega, t_comp, seed, effects):
    try:
        scene = couette_scene(counts=counts, effects=effects, geometry={
            "inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
            "compression_time": t_comp, "omega_inner": omega})
        scene = type(scene)(**{**scene.__dict__,
                               "info": type(scene.info)(**{**scene.info.__dict__, "seed": seed})})
        sim = Simulation(scene)
    except SceneError as e:
        refused(e)
    try:
        sim.advance_steps(1500)  # through most of the compression
    except SimulationError as e:  # pragma: no cover - this is the failure hypothesis looks for
        raise AssertionError(f"{e}") from e
    s = sim.gathered("position", "velocity")
    x, v = s["position"][: sim.n_free], s["velocity"][: sim.n_free]
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(v))
    r = np.hypot(*x.T)
    assert r.min() > 0.05 and r.max() < 0.11


@settings(max_examples=60, deadline=None)
@given(counts=st.tuples(st.integers(1, 300), st.integers(0, 60)), seed=st.integers(0, 10**6),
       start=st.floats(0.095, 0.2))
def test_initial_placement_never_overlaps(counts, seed, start):
    """Random placement (any density the loader accepts): no two disks overlap, and every disk
    is clear of both rings' wall disks (found by the engine test above: a lone disk was once
    jittered across the outer ring)."""
    from pardem.input.placement import initial_configuration

    try:
        scene = couette_scene(counts=counts, geometry={
            "inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": start})
        scene = type(scene)(**{**scene.__dict__,
                               "info": type(scene.info)(**{**scene.info.__dict__, "seed": seed})})
        init = initial_configuration(scene)
    except SceneError as e:
        assert "cannot place" in str(e)
        event("refused: cannot place")
        assume(False)
    n = init.n_free
    x, a = init.x[:n], init.radius[:n]
    r = np.hypot(*x.T)
    wall = 1.25e-3
    assert np.all(r - a >= 0.05 + wall) and np.all(r + a <= start - wall)
    d = np.hypot(*(x[:, None] - x[None]).T)
    np.fill_diagonal(d, np.inf)
    assert np.all(d >= a[:, None] + a[None, :])

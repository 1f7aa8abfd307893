"""Scene builders and analytic references shared by the tests."""

from __future__ import annotations

import math
import time

import numpy as np

from pardem.input.schema import scene_from_dict
from pardem.simulation import Simulation
from pardem.testing import dense_packing  # noqa: F401 (re-exported for the tests)

D_SMALL, M_SMALL = 7.42e-3, 0.275e-3
D_LARGE, M_LARGE = 8.99e-3, 0.490e-3
K_N, GAMMA_N, K_T, MU = 352.1, 0.19, 267.1, 0.44

def kill_when(proc, ready, timeout: float = 300.0, poll: float = 0.02):
    """Wait until ``ready()`` is true, the child ``proc`` exits or ``timeout`` s pass (a cold
    numba cache compiles for a minute or more), then SIGKILL and reap it, whatever happens.
    Returns ``(ready, exit code before the kill or None)``."""
    reached, exited = False, None
    try:
        deadline = time.time() + timeout
        while time.time() < deadline and proc.poll() is None:
            reached = ready()
            if reached:
                break
            time.sleep(poll)
        exited = proc.poll()
    finally:
        proc.kill()
        proc.wait(timeout=30)
    return reached, exited


NO_EFFECTS = {"normal_damping": False, "tangential_friction": False, "rotation": False,
              "bottom_friction": False, "clip_attractive_normal": False}


def free_scene(particles, effects=None, contact=None, time=None, name="test", neighbors=None):
    """A free scene from a list of particle dicts (x, y, vx, vy, omega, diameter, mass);
    ``contact`` overrides the test law's keys (None: leave the key out)."""
    d = {"scene": {"name": name, "kind": "free", "seed": 1},
         "particles": [dict(p) for p in particles],
         "effects": {**NO_EFFECTS, **(effects or {})},
         "contact": {k: v for k, v in {"k_n": K_N, "gamma_n": GAMMA_N, "k_t": K_T, "mu": MU,
                                       **(contact or {})}.items() if v is not None},
         "time": {"dt": "auto", "end": 1.0, **(time or {})}}
    if neighbors:
        d["neighbors"] = neighbors
    return scene_from_dict(d)


def couette_scene(counts=(2545, 394), geometry=None, effects=None, time=None, output=None,
                  name="couette-test", averaging=None, neighbors=None, contact=None):
    d = {"scene": {"name": name, "kind": "couette", "seed": 3},
         "geometry": {**(geometry or {})},
         "species": [{"name": "small", "diameter": D_SMALL, "mass": M_SMALL, "count": counts[0]},
                     {"name": "large", "diameter": D_LARGE, "mass": M_LARGE, "count": counts[1]}],
         "effects": {**(effects or {})},
         "time": {"dt": "auto", "end": 1.0, **(time or {})}}
    if contact:
        d["contact"] = contact
    if output:
        d["output"] = output
    if averaging:
        d["averaging"] = averaging
    if neighbors:
        d["neighbors"] = neighbors
    if d["species"][1]["count"] == 0:
        d["species"].pop()
    return scene_from_dict(d)


def analytic_collision(m_red: float, k_n: float = K_N, gamma_n: float = GAMMA_N):
    """(t_c, e_n) of the damped linear spring (SPEC §3), independent of the code under test."""
    eta = gamma_n / (2 * m_red)
    w = math.sqrt(k_n / m_red - eta**2)
    return math.pi / w, math.exp(-math.pi * eta / w)


def wall_setup(target: str, dt="auto", contact=None):
    """One small disk moving radially into the inner ring: between two wall disks (flat ring
    surface) or straight at a wall disk. Ring at rest, no compression; ``contact``: the
    [contact] table (default: the paper's law). Returns ``(sim, overlap(sim),
    approach_speed(sim))``."""
    spacing = 0.05  # few wall disks, so the flat surface between them is wide
    sc = couette_scene(counts=(1, 0), geometry={"omega_inner": 0.0, "compression_time": 0.0,
                                                "outer_start_radius": 0.2525,
                                                "wall_particle_spacing": spacing},
                       effects={"tangential_friction": False, "bottom_friction": False},
                       time={"dt": dt}, contact=contact)
    sim = Simulation(sc)
    a, r_in, aw = D_SMALL / 2, 0.1035, 1.25e-3
    kind = sim.gathered("kind")["kind"]
    phi = math.pi / np.sum(kind == 1) if target == "flat" else 0.0
    r0 = r_in + a + 1e-4 + (aw if target == "disk" else 0.0)
    e_r = np.array([math.cos(phi), math.sin(phi)])
    sim.set_particles(0, position=r0 * e_r, velocity=-0.05 * e_r)
    wall = np.nonzero(kind == 1)[0][0]

    def overlap(s):
        x = s.gathered("position")["position"]
        if target == "flat":
            return a - (np.hypot(*x[0]) - r_in)
        return a + aw - np.hypot(*(x[0] - x[wall]))

    return sim, overlap, lambda s: -(s.gathered("velocity")["velocity"][0] @ e_r)


def head_on(y, species, masses, gap=1e-4):
    """Two disks of the given species and masses meeting head on along x at height y."""
    return [{"x": -(D_SMALL + gap) / 2, "y": y, "vx": 0.05, "diameter": D_SMALL,
             "mass": masses[0], "species": species[0]},
            {"x": (D_SMALL + gap) / 2, "y": y, "vx": -0.05, "diameter": D_SMALL,
             "mass": masses[1], "species": species[1]}]


def collisions(sim, pairs, max_steps=100_000):
    """(contact time s, restitution) of each pair (i, j) of particles meeting head on along x,
    the contact's start and end interpolated between steps (testing.measure, for several)."""
    def overlap(x, i, j):
        return D_SMALL - (x[j, 0] - x[i, 0])

    x = sim.gathered("position")["position"]
    v = sim.gathered("velocity")["velocity"]
    before = [overlap(x, i, j) for i, j in pairs]
    v_in = [v[i, 0] - v[j, 0] for i, j in pairs]
    start, out = [None] * len(pairs), [None] * len(pairs)
    for k in range(1, max_steps):
        sim.advance_steps(1)
        x = sim.gathered("position")["position"]
        for q, (i, j) in enumerate(pairs):
            d, d0 = overlap(x, i, j), before[q]
            if start[q] is None and d > 0 >= d0:
                start[q] = (k - 1 + d0 / (d0 - d)) * sim.dt
            elif start[q] is not None and out[q] is None and d <= 0 < d0:
                v = sim.gathered("velocity")["velocity"]
                out[q] = ((k - 1 + d0 / (d0 - d)) * sim.dt - start[q],
                          -(v[i, 0] - v[j, 0]) / v_in[q])
            before[q] = d
        if all(out):
            return out
    raise RuntimeError("a collision did not finish")

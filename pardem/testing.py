"""Reference experiments and references shared by the tests and the accuracy study
(run_scripts/studies/accuracy_study.py).

Stage: verification. ``two_disks`` sets up the head-on collision of SPEC §3 and ``measure``
times it: contact start and end are the zero crossings of the overlap, linearly interpolated
between steps, and the restitution is the ratio of the separation and approach speeds.
``brute_force_pairs`` is the O(N^2) reference of the neighbour search. ``dense_cell`` and
``settled_kinetic_energy`` measure the stability limit (tests/hard/test_stability_hard.py,
run_scripts/studies/stability_table.py).
"""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction
from unittest import mock

import numpy as np

from .input.schema import scene_from_dict
from . import builder
from .simulation import Simulation, SimulationError
from .contact.damped_spring import contact_time
from .core.scales import smallest_contact_time
from .core.stability import stability_limit

D_S, M_S = 7.42e-3, 0.275e-3  # the paper's small disks (m, kg)


def two_disks(d: float, m: float, dt, phase: float = 0.0, integrator: str = "verlet",
              k_n: float = 352.1, gamma_n: float = 0.19):
    """Two equal disks (diameter d m, mass m kg) approaching head on at 0.1 m/s, damping only;
    ``phase`` (0..1) shifts the moment of first contact by that fraction of a step of t_c/50
    (or of ``dt``, s). Returns ``(sim, overlap(sim), approach_speed(sim))``."""
    step = contact_time(k_n, gamma_n, m / 2) / 50 if dt == "auto" else dt
    gap = 1e-4 + phase * 0.1 * step
    no = {"normal_damping": True, "tangential_friction": False, "rotation": False,
          "bottom_friction": False, "clip_attractive_normal": False}
    ps = [{"x": -(d + gap) / 2, "y": 0.0, "vx": 0.05, "diameter": d, "mass": m},
          {"x": (d + gap) / 2, "y": 0.0, "vx": -0.05, "diameter": d, "mass": m}]
    sim = Simulation(scene_from_dict({
        "scene": {"name": "two-disks", "kind": "free", "seed": 1}, "particles": ps,
        "effects": no, "contact": {"k_n": k_n, "gamma_n": gamma_n, "k_t": 0.0, "mu": 0.0},
        "time": {"dt": dt, "end": 1.0, "integrator": integrator}}))
    return (sim, *head_on_probes(d))


def head_on_probes(d: float):
    """``(overlap(sim), approach_speed(sim))`` of two disks of diameter d meeting along x,
    particle 0 on the left."""
    def overlap(s):
        x = s.gathered("position")["position"]
        return d - (x[1, 0] - x[0, 0])

    def approach(s):
        v = s.gathered("velocity")["velocity"]
        return v[0, 0] - v[1, 0]

    return overlap, approach


def measure(sim, overlap, rel_speed, max_steps: int = 200_000) -> tuple[float, float]:
    """Step until the contact is over; return (contact time s, restitution)."""
    dt = sim.dt
    d_prev, v_in, t_start = overlap(sim), rel_speed(sim), None
    for k in range(1, max_steps):
        sim.advance_steps(1)
        d = overlap(sim)
        if t_start is None and d > 0 >= d_prev:
            t_start = (k - 1 + d_prev / (d_prev - d)) * dt
        elif t_start is not None and d <= 0 < d_prev:
            t_end = (k - 1 + d_prev / (d_prev - d)) * dt
            return t_end - t_start, -rel_speed(sim) / v_in
        d_prev = d
    raise RuntimeError("collision did not finish")


def dense_packing(nx: int, ny: int, spacing_factor: float = 0.995, speed: float = 0.05,
                  seed: int = 0):
    """Triangular patch of small disks, slightly compressed, with random velocities and spins."""
    rng = np.random.default_rng(seed)
    s = D_S * spacing_factor
    out = []
    for j in range(ny):
        for i in range(nx):
            out.append({"x": (i + 0.5 * (j % 2)) * s, "y": j * s * math.sqrt(3) / 2,
                        "vx": float(rng.normal(0, speed)), "vy": float(rng.normal(0, speed)),
                        "omega": float(rng.normal(0, 5.0)), "diameter": D_S,
                        "mass": M_S})
    return out


def elastic_gas_energy_error(dt_per_contact: float, steps: int, seed: int,
                             integrator: str = "verlet") -> tuple[float, float]:
    """Mean and worst relative deviation of the total energy (50 samples over ``steps``) of an
    elastic gas of 250 disks (area fraction 0.6) between two fixed rings, every dissipative
    effect switched off, dt = t_c / dt_per_contact exactly (not shortened to divide the time
    quantum: an order in dt is measured from these)."""
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.09,
         "compression_time": 0.0, "omega_inner": 0.0}
    off = {k: False for k in ("normal_damping", "tangential_friction", "rotation",
                              "bottom_friction")}
    scene = scene_from_dict({
        "scene": {"name": "elastic-gas", "kind": "couette", "seed": 3}, "geometry": g,
        "species": [{"name": "small", "diameter": D_S, "mass": M_S, "count": 250}],
        "effects": off, "time": {"integrator": integrator}})
    dt = smallest_contact_time(scene) / dt_per_contact
    sim = Simulation(dataclasses.replace(scene, time=dataclasses.replace(scene.time, dt=dt)))
    rng = np.random.default_rng(seed)
    sim.set_particles(np.arange(sim.n_free), velocity=rng.normal(0.0, 0.1, (sim.n_free, 2)))
    e0 = sim.total_energy()
    errs, contacts = [], 0
    for _ in range(50):
        sim.advance_steps(steps // 50)
        errs.append(abs(sim.total_energy() / e0 - 1))
        contacts += sim.contacts()["ids"].shape[0]
    if contacts <= 100:
        raise RuntimeError("the gas had too few collisions to test anything")
    return float(np.mean(errs)), float(np.max(errs))


def brute_force_pairs(x: np.ndarray, radius: np.ndarray, gid: np.ndarray, kind: np.ndarray,
                      skin: float, wall_skin: float = 0.0) -> set[tuple[int, int]]:
    """Reference O(N^2) search: the set of (gid_lo, gid_hi) within a + a' + skin with at least
    one free particle (kind 0); pairs with a wall disk (kind != 0) within wall_skin more."""
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=-1)
    walls = (kind[:, None] != 0) | (kind[None, :] != 0)
    cut = radius[:, None] + radius[None, :] + skin + wall_skin * walls
    ii, jj = np.nonzero((d < cut) & (gid[:, None] < gid[None, :]))
    return {(int(gid[i]), int(gid[j])) for i, j in zip(ii, jj) if kind[i] == 0 or kind[j] == 0}


def dense_cell(effects: dict | None = None, contact: dict | None = None, count: int = 340):
    """A small, dense Couette cell that is not sheared: ``count`` of the paper's small disks
    (340: volume fraction 0.835, about four contacts per disk, overlaps up to ~8 % d)
    compressed from R_o = 0.11 to 0.09 m in 0.1 s around R_i = 0.05 m, then left to settle;
    ``effects`` and ``contact`` change the defaults."""
    return scene_from_dict({
        "scene": {"name": "dense-cell", "kind": "couette", "seed": 3},
        "geometry": {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
                     "compression_time": 0.1, "omega_inner": 0.0},
        "species": [{"name": "small", "diameter": D_S, "mass": M_S, "count": count}],
        "effects": dict(effects or {}), "contact": dict(contact or {}), "time": {"end": 1.0}})


SETTLE_TIMES = tuple(0.3 + 0.01 * k for k in range(11))  # s: 0.2-0.3 s after the compression


def settled_kinetic_energy(scene, dt: float, spin: float = 0.0) -> float:
    """Median kinetic energy (J) of the free disks at SETTLE_TIMES, run at step ``dt`` (s) even
    beyond the admitted limit (resolve_step is bypassed: this measures where that limit must
    be). A stable step lets a damped packing come to rest (KE falls by orders of magnitude
    after the compression); an unstable mode keeps it chattering at the springs' Coulomb
    limits, or blows it up (``inf``: the watchdog stopped it). The median, because a settling
    frictionless packing still rearranges now and then. ``spin`` (rad/s): the spread of random
    spins given to the disks when the compression ends: without friction nothing else turns
    a disk, and a mode of the rolling springs needs a seed to grow."""
    step = Fraction(repr(float(dt)))
    scene = dataclasses.replace(scene, time=dataclasses.replace(scene.time, dt=float(step)))
    with mock.patch.object(builder, "resolve_step", lambda _: step):
        sim = Simulation(scene)
    ke = []
    try:
        if spin:
            sim.run(end=scene.geometry.compression_time, progress=False)
            rng = np.random.default_rng(1)
            sim.set_particles(np.arange(sim.n_free), omega=rng.normal(0.0, spin, sim.n_free))
        for t in SETTLE_TIMES:
            sim.run(end=t, progress=False)
            ke.append(sim.kinetic_energy())
    except SimulationError:
        return math.inf
    return float(np.median(ke))


def stability_drift(scene, ratios, spin: float = 0.0) -> tuple[float, float, list[float]]:
    """``(limit s, KE at t_c/50 J, [KE(ratio x limit) / KE(t_c/50)])`` of ``dense_cell``
    scene (``settled_kinetic_energy``): how much more the settled packing moves at each
    multiple of the admitted limit."""
    limit, _ = stability_limit(scene)
    ref = settled_kinetic_energy(scene, smallest_contact_time(scene) / 50, spin)
    return limit, ref, [settled_kinetic_energy(scene, r * limit, spin) / ref for r in ratios]

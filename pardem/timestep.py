"""Time step from the analytic contact time of the linear spring-dashpot (SPEC §3;
contact.model.contact_time). The default step is t_c(smallest pair) / dt_per_contact; a step
above t_c/5 is refused.

The linear spring resolves a contact in time independently of the impact speed, but the overlap
grows with it: a disk hit head-on by a wall moving at v overlaps it by up to v/omega_0 (omega_0
of the disk against the infinitely massive wall). Ring speeds that would push that beyond
MAX_IMPACT_OVERLAP of the smallest diameter are refused: disks would pass through each other.
Units SI: N/m, kg/s, kg, s.
"""

from __future__ import annotations

import math

import numpy as np

from .contact import model
from .scene import Scene, SceneError


def contact_time(k_n: float, gamma_n: float, m_red: float) -> float:
    """t_c (s) of the damped normal spring; SceneError when the contact is overdamped."""
    try:
        return model.contact_time(k_n, gamma_n, m_red)
    except ValueError as e:
        raise SceneError(f"[contact] gamma_n = {gamma_n!r}: {e} for reduced mass {m_red:.4g} "
                         "kg; a contact never ends, so there is no t_c (kg/s)") from None


def smallest_reduced_mass(scene: Scene) -> float:
    """Smallest reduced mass (kg) over pairs of free particles: that of the two lightest ones.

    A lighter partner always lowers m_red, so the two lightest particles decide; one particle of a
    species cannot pair with itself. With a single free particle the only partners are walls
    (infinitely massive), so m_red = m.
    """
    if scene.particles is not None:
        m = np.asarray(scene.particles.mass)
        if m.size == 1:
            return float(m[0])
        a, b = np.partition(m, 1)[:2]
    else:
        ms = sorted((s.mass, s.count) for s in scene.species if s.count > 0)
        if ms[0][1] >= 2:
            a = b = ms[0][0]
        elif len(ms) > 1:
            a, b = ms[0][0], ms[1][0]
        else:
            return float(ms[0][0])
    return float(a * b / (a + b))


def smallest_contact_time(scene: Scene) -> float:
    """t_c (s) of the pair with the smallest reduced mass; gamma_n counts only if the scene
    switches normal damping on."""
    c = scene.contact
    gamma = c.gamma_n if scene.effects.normal_damping else 0.0
    return contact_time(c.k_n, gamma, smallest_reduced_mass(scene))


MAX_IMPACT_OVERLAP = 0.25  # of the smallest free-particle diameter


def free_disks(scene: Scene) -> list[tuple[float, float]]:
    """(diameter m, mass kg) of every kind of free disk in the scene."""
    if scene.particles is not None:
        return list(zip(np.asarray(scene.particles.diameter, float),
                        np.asarray(scene.particles.mass, float)))
    return [(s.diameter, s.mass) for s in scene.species if s.count > 0]


def check_wall_speeds(scene: Scene) -> None:
    """SceneError if the inner ring's surface speed or the outer ring's largest compression speed
    would drive a head-on overlap beyond MAX_IMPACT_OVERLAP of the hit disk's diameter. The
    overlap at speed v is up to v sqrt(m/k_n) (the undamped spring against an infinitely massive
    wall), so the heaviest disk for its size decides. An outer ring that starts wider than its
    final radius needs a compression time (0 would move it at infinite speed)."""
    g = scene.geometry
    if g is None:
        return
    worst = max(math.sqrt(m / scene.contact.k_n) / d for d, m in free_disks(scene))  # s/m
    limit = MAX_IMPACT_OVERLAP / worst  # m/s
    gap = g.outer_start_radius - g.outer_radius
    if gap > 0 and g.compression_time <= 0:
        raise SceneError(
            f"[geometry] compression_time = {g.compression_time!r}: the outer ring must move "
            f"{gap:.4g} m from outer_start_radius to outer_radius; give it a compression time "
            f"(at least {0.5 * math.pi * gap / limit:.4g} s), or start at the final radius (s)")
    speeds = [("omega_inner", abs(g.omega_inner) * g.inner_radius, "rad/s",
               limit / g.inner_radius, "|omega_inner| <=")]
    if g.compression_time > 0:
        rate = 0.5 * math.pi * gap / g.compression_time
        speeds.append(("compression_time", rate, "s", 0.5 * math.pi * gap / limit,
                       "compression_time >="))
    for key, v, unit, bound, rule in speeds:
        if v > limit:
            raise SceneError(
                f"[geometry] {key} = {getattr(g, key)!r}: the ring surface moves at up to "
                f"{v:.3g} m/s; a disk hit at that speed overlaps it by up to v sqrt(m/k_n) = "
                f"{100 * v * worst:.0f} % of its diameter, beyond the "
                f"{100 * MAX_IMPACT_OVERLAP:.0f} % the contact model resolves; use {rule} "
                f"{bound:.4g} {unit}, or a stiffer k_n")


def resolve_dt(scene: Scene) -> float:
    """The run's time step (s): [time] dt, or t_c / dt_per_contact when dt = "auto".

    Raises SceneError when dt > t_c/5 (a contact would be resolved by fewer than five steps) or
    when a ring moves too fast for the contact law (``check_wall_speeds``).
    """
    check_wall_speeds(scene)
    t_c = smallest_contact_time(scene)
    dt = scene.time.dt if scene.time.dt is not None else t_c / scene.time.dt_per_contact
    if dt > t_c / 5.0:
        raise SceneError(
            f"[time] dt = {dt:.6g} s exceeds t_c/5 = {t_c / 5.0:.3g} s (t_c = {t_c:.4g} s for the "
            'smallest pair); use a smaller dt or dt = "auto"')
    return dt

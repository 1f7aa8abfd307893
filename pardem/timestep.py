"""Time step from the analytic contact time of the linear spring-dashpot (SPEC §3;
contact.model.contact_time). The default step is t_c(smallest pair) / dt_per_contact, shortened
by at most 1 % so that a whole number of steps fills a power of ten of a second (``time_quantum``):
output asked for at multiples of it lands at exactly the times the scene names. A step above
t_c/5 is refused. A run's clock is the step count times ``resolve_step``'s exact fraction of a
second, so that 0.15 s prints as 0.15.

The linear spring resolves a contact in time independently of the impact speed, but the overlap
grows with it: a disk hit head-on by a wall moving at v overlaps it by up to v/omega_0 (omega_0
of the disk against the infinitely massive wall). Ring speeds that would push that beyond
MAX_IMPACT_OVERLAP of the smallest diameter are refused: disks would pass through each other.
Units SI: N/m, kg/s, kg, s.
"""

from __future__ import annotations

import math
from fractions import Fraction

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


def check_free_speeds(scene: Scene, dt: float) -> None:
    """SceneError if a free disk's surface (velocity plus spin at its rim) would move more than
    half its diameter in one step: it could pass through a partner between two steps without
    ever touching it (and speeds like 1e200 m/s overflow the neighbour search)."""
    p = scene.particles
    if p is None:
        return
    speed = np.hypot(p.vx, p.vy) + np.abs(p.omega) * 0.5 * p.diameter
    per_step = speed * dt / p.diameter
    if np.any(per_step > 0.5):
        i = int(np.argmax(per_step))
        raise SceneError(
            f"[[particles]] #{i}: moves at {speed[i]:.3g} m/s (velocity and spin at its rim), "
            f"{per_step[i]:.3g} diameters per step of {dt:.4g} s: it could pass through another "
            f"disk between two steps; at most {0.5 * p.diameter[i] / dt:.3g} m/s at this dt")


STEPS_PER_MODE = 5.0
"""The step may not exceed (pi/omega)/5 of the stiffest enabled contact mode: five steps per
half period (velocity Verlet itself turns unstable at omega dt = 2, i.e. 1.6 steps per half
period, for one contact; many contacts on a disk raise the stiffest frequency of the packing)."""


def _pair_kinds(scene: Scene) -> list[tuple[float, float, int]]:
    """(radius m, mass kg, count) of each kind of free disk."""
    if scene.particles is not None:
        rows = np.column_stack([0.5 * np.asarray(scene.particles.diameter, float),
                                np.asarray(scene.particles.mass, float)])
        kinds, counts = np.unique(rows, axis=0, return_counts=True)
        return [(float(a), float(m), int(c)) for (a, m), c in zip(kinds, counts)]
    return [(0.5 * s.diameter, s.mass, s.count) for s in scene.species if s.count > 0]


def contact_modes(scene: Scene) -> list[tuple[str, float]]:
    """(what, half period pi/omega in s) of each contact mode the scene's effects enable, for
    the pair that makes it stiffest. The normal spring's is the damped t_c of the lightest pair.
    A sticking tangential spring k_t moves the contact point through both translation and
    rotation: 1/m_eff = 1/m_i + 1/m_j + a_i^2/I_i + a_j^2/I_j = 3/m_red for disks (I = m a^2/2),
    1/m_red without rotation. The rolling spring k_r acts on the relative rotation through the
    reduced radius a' = a_i a_j/(a_i + a_j): omega^2 = k_r a'^2 (1/I_i + 1/I_j); against a flat
    ring surface 2 k_r/m_i, the stiffest."""
    c, e = scene.contact, scene.effects
    m_red = smallest_reduced_mass(scene)
    modes = [("the normal spring k_n (t_c of the lightest pair)", smallest_contact_time(scene))]
    if e.tangential_friction and c.k_t > 0 and c.mu > 0:  # mu = 0: the spring never sticks
        share = 3.0 if e.rotation else 1.0
        what = ("the sticking tangential spring with rotation, omega^2 = 3 k_t/m_red"
                if e.rotation else "the sticking tangential spring, omega^2 = k_t/m_red")
        modes.append((what, math.pi / math.sqrt(share * c.k_t / m_red)))
    if e.rolling_resistance and e.rotation and c.k_r > 0:
        kinds = _pair_kinds(scene)
        lightest = min(m for _, m, _ in kinds)
        # against a flat ring surface a' = a_i and the ring does not turn back: 2 k_r/m_i,
        # which also bounds every pair (a'^2 (1/I_i + 1/I_j) <= 2/min(m_i, m_j))
        if scene.geometry is not None:
            w2 = 2.0 * c.k_r / lightest
        elif len(kinds) > 64:  # many kinds of free disk: a cruder bound, 2/m_red
            w2 = 2.0 * c.k_r / m_red
        else:
            w2 = max((c.k_r * (ai * aj / (ai + aj)) ** 2 * 2.0 * (1 / (mi * ai**2)
                                                                 + 1 / (mj * aj**2))
                      for i, (ai, mi, ni) in enumerate(kinds)
                      for j, (aj, mj, _) in enumerate(kinds) if i != j or ni >= 2), default=0.0)
        if w2 > 0:
            modes.append(("the rolling spring, omega^2 = k_r a'^2 (1/I_i + 1/I_j)",
                          math.pi / math.sqrt(w2)))
    return modes


def stability_limit(scene: Scene) -> tuple[float, str]:
    """The largest admitted step (s), (pi/omega)/STEPS_PER_MODE of the stiffest enabled mode,
    and that mode."""
    what, half = min(contact_modes(scene), key=lambda m: m[1])
    return half / STEPS_PER_MODE, what


QUANTUM_STEPS = 100
"""With dt = "auto" the step divides the time quantum, the power of ten that holds at least this
many steps of t_c / dt_per_contact (10 ms for the paper's material): aligning costs at most 1 %
more steps, and the step depends on the material only, never on the output settings (a restart
with other intervals keeps its step)."""


def _decimal(t: float) -> Fraction:
    return Fraction(repr(float(t)))  # the value as written in the scene: 0.1 is 1/10


def time_quantum(longest: float) -> Fraction:
    """The smallest power of ten (s) of at least QUANTUM_STEPS steps of ``longest``."""
    return Fraction(10) ** math.ceil(math.log10(QUANTUM_STEPS * longest))


def output_times(scene: Scene) -> list[tuple[str, float]]:
    """(key, s) of every time at which the scene asks for output."""
    out, avg = scene.output, scene.averaging
    keys = [("[time] end", scene.time.end),
            ("[output] snapshot_interval", out.snapshot_interval),
            ("[output] checkpoint_interval", out.checkpoint_interval)]
    if avg is not None:
        keys += [("[averaging] start", avg.start), ("[averaging] end", avg.end),
                 ("[averaging] sample_interval", avg.sample_interval)]
    return [(k, t) for k, t in keys if math.isfinite(t)]


def off_step(scene: Scene, step: Fraction) -> list[str]:
    """The output times of the scene that are not a whole number of steps ("key = value s"),
    to a millionth of a step: these are rounded to the nearest step."""
    dt = float(step)
    return [f"{key} = {t:g} s" for key, t in output_times(scene)
            if abs(t / dt - round(t / dt)) > 1e-6]


def off_step_text(scene: Scene, step: Fraction) -> str | None:
    """``off_step`` as words ("key = value s, ... not a whole number of steps of dt s"), None
    if every output time is a whole number of steps."""
    off = off_step(scene, step)
    return f"{', '.join(off)} not a whole number of steps of {float(step):.6g} s" if off else None


def resolve_step(scene: Scene) -> Fraction:
    """The run's time step as an exact fraction of a second: [time] dt as written, or with dt =
    "auto" the time quantum over the fewest whole steps no longer than t_c / dt_per_contact, so
    that output at any multiple of the quantum lands on a step and its time prints exactly.

    Raises SceneError when dt exceeds ``stability_limit`` (five steps per half period of the
    stiffest enabled contact mode: for frictional disks the sticking tangential spring with
    rotation, 3 k_t against k_n) or when a ring moves too fast for the contact law
    (``check_wall_speeds``).
    """
    check_wall_speeds(scene)
    t_c = smallest_contact_time(scene)
    if scene.time.dt is not None:
        step = _decimal(scene.time.dt)
    else:
        longest = t_c / scene.time.dt_per_contact
        quantum = time_quantum(longest)
        step = quantum / math.ceil(quantum / Fraction(longest))
    dt = float(step)
    check_free_speeds(scene, dt)
    limit, what = stability_limit(scene)
    if dt > limit:
        key = "dt" if scene.time.dt is not None else "dt_per_contact"
        given = f"{dt:.6g}" if key == "dt" else f"{scene.time.dt_per_contact:g} (dt = {dt:.4g} s)"
        raise SceneError(
            f"[time] {key} = {given}: dt exceeds the stability limit {limit:.4g} s = "
            f"(pi/omega)/{STEPS_PER_MODE:g} of the stiffest contact mode, {what} (pi/omega = "
            f"{STEPS_PER_MODE * limit:.4g} s); use dt <= {limit:.4g} s, i.e. dt_per_contact >= "
            f"{t_c / limit:.3g} (t_c = {t_c:.4g} s)")
    return step


def resolve_dt(scene: Scene) -> float:
    """``resolve_step`` as a float (s)."""
    return float(resolve_step(scene))

"""The run's time step: t_c(smallest pair) / dt_per_contact (scales.py), shortened by at most
1 % so that a whole number of steps fills a power of ten of a second (``time_quantum``):
output asked for at multiples of it lands at exactly the times the scene names. A step above
stability.stability_limit is refused. A run's clock is the step count times
``resolve_step``'s exact fraction of a second, so that 0.15 s prints as 0.15.

An impact's overlap grows with its speed: a disk hit head-on at approach speed u overlaps its
partner by up to u sqrt(m_red/k) for the normal law's loading stiffness k
(scales.normal_stiffness; m_red = m against an infinitely massive ring). Ring speeds and free
disks' speeds that would push that beyond MAX_IMPACT_OVERLAP (contact.overlap.MAX_OVERLAP) of
the smaller diameter are refused: disks would pass through each other (a run that gets there
anyway stops, step.py). Units SI: N/m, kg/s, kg, s.
"""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from ..contact.damped_spring import restitution_beta
from ..contact.overlap import MAX_OVERLAP
from ..contact.pairs import contact_laws, pair_contacts
from .scales import free_disks, normal_stiffness, smallest_contact_time, smallest_reduced_mass
from ..input.scene import Scene, SceneError
from ..input.values import fail, show
from .stability import STEPS_PER_CONTACT, rounded, stability_limit


MAX_IMPACT_OVERLAP = MAX_OVERLAP  # of the smaller diameter of a contact


def check_wall_speeds(scene: Scene) -> None:
    """SceneError if the inner ring's surface speed or the outer ring's largest compression speed
    would drive a head-on overlap beyond MAX_IMPACT_OVERLAP of the hit disk's diameter. The
    overlap at speed v is up to v sqrt(m/k_n) (the undamped spring against an infinitely massive
    wall), so the heaviest disk for its size decides. An outer ring that starts wider than its
    final radius needs a compression time (0 would move it at infinite speed)."""
    g = scene.geometry
    if g is None:
        return
    k_load = softest_load(scene)
    worst = max(math.sqrt(m / k_load) / d for d, m in free_disks(scene))  # s/m
    limit = MAX_IMPACT_OVERLAP / worst  # m/s
    gap = g.outer_start_radius - g.outer_radius
    if gap > 0 and g.compression_time <= 0:
        raise SceneError(
            f"[geometry] compression_time = {g.compression_time!r}: the outer ring must move "
            f"{gap:.4g} m from outer_start_radius to outer_radius; give it a compression time "
            f"(at least {rounded(0.5 * math.pi * gap / limit, 4, down=False)} s), or start at "
            "the final radius (s)")
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
                f"{100 * v * worst:.3g} % of its diameter, beyond the "
                f"{100 * MAX_IMPACT_OVERLAP:.0f} % the contact model resolves; use {rule} "
                f"{rounded(bound, 4, down='<' in rule)} {unit}, or a stiffer k_n")


def softest_load(scene: Scene) -> float:
    """k_load (N/m) of the softest contact law of the scene (the [contact] law's, or a pair
    table's if softer): the deepest impact at a given speed."""
    return min(normal_stiffness(scene, c)[0] for c in contact_laws(scene))


def _free_kinds(p) -> tuple[np.ndarray, np.ndarray]:
    """(diameter m, mass kg) of each distinct kind of free disk in a particles table."""
    kinds = np.unique(np.column_stack([np.asarray(p.diameter, float),
                                       np.asarray(p.mass, float)]), axis=0)
    return kinds[:, 0], kinds[:, 1]


def peak_overlap_time(m_red: np.ndarray, k_n: float, gamma_n: float) -> np.ndarray:
    """delta_max/u (s): the deepest overlap of a head-on collision at approach speed u of the
    damped spring, u/omega_0 exp(-eta t*) at t* = atan(omega_d/eta)/omega_d (eta = gamma_n/
    (2 m_red)); sqrt(m_red/k_n) undamped. Underdamped contacts only (resolve_step refuses the
    others first)."""
    eta = gamma_n / (2.0 * m_red)
    w0 = np.sqrt(k_n / m_red)
    wd = np.sqrt(np.maximum(w0 * w0 - eta * eta, 0.0))
    return np.exp(-eta * np.arctan2(wd, eta) / np.where(wd > 0, wd, 1.0)) / w0


def approach_speed_limit(scene: Scene, dt: float) -> float:
    """The largest approach speed (m/s) at which two free disks of the scene may meet head on:
    the overlap then peaks at u sqrt(m_red/k_n) undamped (``peak_overlap_time`` with normal
    damping), and it may already be u dt deep at the first step that sees the contact, so
    u (peak_overlap_time + dt) <= MAX_OVERLAP min(d_i, d_j) for the worst pair of kinds
    (measured on the discrete Verlet collision, the peak stays below this bound at any phase
    and step up to t_c/3). It also keeps a pair from closing more than MAX_OVERLAP of a
    diameter in one step, so no pair can pass through another between two steps. With more
    than 64 kinds a cruder bound: m_red <= m of either disk, min(d) = one of the two
    diameters, no damping."""
    d, m = _free_kinds(scene.particles)
    laws = contact_laws(scene)
    k_load = softest_load(scene)
    damped, given = scene.effects.normal_damping, scene.contact.restitution is not None
    gamma = min(c.gamma_n for c in laws) if damped and not given else 0.0
    if d.size > 64:
        worst = np.max((np.sqrt(m / k_load) + dt) / d)
    else:
        m_red = m[:, None] * m[None, :] / (m[:, None] + m[None, :])
        if damped and given:  # the least damping of any restitution, at each pair's m_red
            beta = min(restitution_beta(c.restitution) for c in laws)
            gamma = beta * np.sqrt(k_load * m_red)
        worst = np.max((peak_overlap_time(m_red, k_load, gamma) + dt)
                       / np.minimum(d[:, None], d[None, :]))
    return float(MAX_OVERLAP / worst)


def check_free_speeds(scene: Scene, dt: float) -> None:
    """SceneError if two free disks could meet faster than ``approach_speed_limit`` (the two
    fastest: no approach speed exceeds the sum of theirs), or a disk's surface (velocity plus
    spin at its rim) would move more than half its diameter in one step (and speeds like
    1e200 m/s overflow the neighbour search)."""
    p = scene.particles
    if p is None:
        return
    v = np.hypot(p.vx, p.vy)
    if v.size >= 2:
        i, j = (int(k) for k in np.argsort(-v, kind="stable")[:2])
        u, limit = float(v[i] + v[j]), approach_speed_limit(scene, dt)
        if u > limit:
            raise SceneError(
                f"free particles #{i} and #{j} (0-based, in the order given) move at "
                f"{v[i]:.3g} and {v[j]:.3g} m/s: head on they would meet at {u:.3g} m/s and "
                "overlap by up to "
                f"{100 * MAX_OVERLAP * u / limit:.3g} % of the smaller diameter, beyond the "
                f"{100 * MAX_OVERLAP:.0f} % the contact law represents (they could pass "
                f"through each other); at dt = {dt:.4g} s and k_n = {scene.contact.k_n:g} N/m "
                f"disks may approach at up to {limit:.3g} m/s (two at +-{limit / 2:.3g} m/s)")
    speed = v + np.abs(p.omega) * 0.5 * p.diameter
    per_step = speed * dt / p.diameter
    if np.any(per_step > 0.5):
        i = int(np.argmax(per_step))
        raise SceneError(
            f"free particle #{i} (0-based, in the order given): moves at {speed[i]:.3g} m/s "
            f"(velocity and spin at its rim), {per_step[i]:.3g} diameters per step of "
            f"{dt:.4g} s: it could pass through another "
            f"disk between two steps; at most {rounded(0.5 * p.diameter[i] / dt, 3, down=True)} "
            "m/s at this dt")


def check_adhesion(scene: Scene, dt: float) -> None:
    """SceneError if a Luding law's tension branch, f = -k_adhesion delta, is stiffer than a
    step of dt s resolves. On it the overlap of a pair of reduced mass m_red follows
    m_red delta'' = k_adhesion delta: it grows or decays like exp(t sqrt(k_adhesion/m_red)),
    a time the step must follow as it follows a collision (stability.STEPS_PER_CONTACT steps
    per pi sqrt(m_red/k), the lightest pair's m_red the fastest). So k_adhesion <= m_red
    (pi/(5 dt))^2: k_unload at the coarsest step the resolution rule admits (t_c/5 of
    k_unload), about 100 k_unload at the default dt (t_c/50). The time step does not follow
    k_adhesion, so nothing else bounds it: k_adhesion = 1e300 would turn the branch into a
    jump of the force no step resolves (and overflow the pair tables' mixing)."""
    most = smallest_reduced_mass(scene) * (math.pi / (STEPS_PER_CONTACT * dt)) ** 2  # N/m
    tables = [(f"[[contact.pair]] #{i} {show(p.species[0])}-{show(p.species[1])}", c)
              for i, (p, (_, c)) in enumerate(zip(scene.pairs, pair_contacts(scene)))]
    for label, c in [("[contact]", scene.contact)] + tables:
        if c.normal == "luding" and c.k_adhesion > most:
            raise fail(label, "k_adhesion", c.k_adhesion,
                       f"Luding's tension branch -k_adhesion delta changes a pair's overlap "
                       f"like exp(t sqrt(k_adhesion/m_red)), faster than a step of dt = "
                       f"{dt:.4g} s follows: with {STEPS_PER_CONTACT:g} steps per pi "
                       f"sqrt(m_red/k_adhesion), as a collision gets per contact time, and the "
                       f"lightest pair's m_red = {smallest_reduced_mass(scene):.4g} kg, "
                       f"k_adhesion may be at most {rounded(most, 4, down=True)} N/m (k_unload "
                       f"= {c.k_unload:g} N/m); lower it, or shorten dt", "N/m")


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


MAX_STEPS = 1e12
"""More steps than any run can take: at 25 M particle-steps/s (check.REFERENCE_RATE) 1e12 steps
of a single disk take 11 hours, of the paper's 2,939 disks 4 years. A count beyond it comes
from a typo (k_n = 1e300 gives dt = 7e-154 s) and would otherwise only show as a run that
never ends."""


def check_step_count(scene: Scene, dt: float, end: float, key: str, start: float = 0.0) -> None:
    """SceneError if running from ``start`` to ``end`` s (given as ``key``) takes more than
    MAX_STEPS steps of dt s, naming the count and what sets dt."""
    steps = (end - start) / dt
    if not steps > MAX_STEPS:
        return
    if scene.time.dt is not None:
        source = f"[time] dt = {scene.time.dt:g} s"
    else:
        c = scene.contact
        source = (f"t_c/{scene.time.dt_per_contact:g} ([time] dt_per_contact) with the contact "
                  f"time t_c = {smallest_contact_time(scene):.3g} s of [contact] k_n = {c.k_n:g} "
                  f"N/m and the lightest pair's reduced mass {smallest_reduced_mass(scene):.3g} kg")
    raise SceneError(
        f"{key} = {end:g} s is {steps:.3g} steps of dt = {dt:.3g} s, more than {MAX_STEPS:.0e} "
        f"({steps / 25e6 / 3.156e7:.3g} years even for one disk at 25 M particle-steps/s): dt is "
        f"{source}; shorten the run, or check the key that sets dt (a stiffer k_n than the "
        "material needs only shortens the step)")


def resolve_step(scene: Scene) -> Fraction:
    """The run's time step as an exact fraction of a second: [time] dt as written, or with dt =
    "auto" the time quantum over the fewest whole steps no longer than t_c / dt_per_contact, so
    that output at any multiple of the quantum lands on a step and its time prints exactly.

    Raises SceneError when dt exceeds ``stability_limit`` (t_c/5, or the largest stable step of
    the stiffest mode of the densest packing: for the paper's material its damped translation,
    t_c/11), when a ring moves too fast for the contact law (``check_wall_speeds``) or free
    disks would meet too fast (``check_free_speeds``) or a Luding law's tension branch is
    stiffer than the step resolves (``check_adhesion``).
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
    check_adhesion(scene, dt)
    limit, what = stability_limit(scene)
    if dt > limit:
        # the limit rounded down, the step and the ratio rounded up: each printed bound holds
        # as printed (dt = the printed limit is accepted), and dt never prints as the limit
        key = "dt" if scene.time.dt is not None else "dt_per_contact"
        given = (repr(scene.time.dt) if key == "dt" else
                 f"{scene.time.dt_per_contact:g} (dt = {rounded(dt, 4, down=False)} s)")
        bound, ratio = rounded(limit, 4, down=True), rounded(t_c / limit, 3, down=False)
        raise SceneError(
            f"[time] {key} = {given}: dt exceeds the stability limit {bound} s = t_c/"
            f"{ratio}, set by {what}; use dt <= {bound} s, i.e. dt_per_contact >= {ratio} "
            f"(t_c = {t_c:.4g} s)")
    check_step_count(scene, dt, scene.time.end, "[time] end")
    return step


def resolve_dt(scene: Scene) -> float:
    """``resolve_step`` as a float (s)."""
    return float(resolve_step(scene))

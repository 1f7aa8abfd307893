"""The largest stable time step of a scene: the resolution rule (STEPS_PER_CONTACT steps per
contact time) and the stiffest modes of the densest packing that its effects enable
(``contact_modes``), each under pardem's velocity Verlet (``mode_step_limit``);
timestep.resolve_step refuses a step above ``stability_limit`` (docs/accuracy.md, "Stability
limit"). Units SI.
"""

from __future__ import annotations

import math
from decimal import ROUND_CEILING, ROUND_FLOOR, Decimal

import numpy as np

from ..contact.damped_spring import contact_gamma
from ..contact.damping import tangential_gamma
from ..contact.pairs import contact_laws
from .scales import normal_stiffness, smallest_contact_time, smallest_reduced_mass
from ..input.scene import Scene
from ..input.species import all_disks


STEPS_PER_CONTACT = 5.0
"""Resolution: at least five steps per contact time t_c of the lightest pair. Fewer steps leave
a collision to two or three force samples, and the energy of an elastic gas drifts although
no mode is unstable (docs/accuracy.md, "Stability limit")."""

PACKING_CONTACTS = 6
"""Contacts of a disk in the densest packing of equal disks (hexagonal): the stiffest modes of
any packing are bounded by those of this one (Rayleigh quotient; exact for the hexagonal
packing, see ``contact_modes``)."""


def mode_step_limit(w_verlet2: float, w_explicit2: float, c: float) -> float:
    """The largest stable step (s) of one mode x'' = -w_v^2 x - w_e^2 xi - c x' under pardem's
    velocity Verlet: x from the half-step velocity (symplectic), the damping c (1/s) and the
    spring xi (incremented by the velocity, xi' = x') from the velocity predicted at the end
    of the step. Its amplification matrix gets the eigenvalue -1 where (w_v^2 + 2 w_e^2) dt^2
    + 4 c dt = 4, and no other boundary is crossed first (checked against its spectral radius
    in tests/hard/test_stability_hard.py), so dt* = 2 (sqrt(c^2 + W^2) - c)/W^2 with W^2 =
    w_v^2 + 2 w_e^2: 2/w for Verlet's spring, sqrt(2)/w for an explicitly incremented one
    (an extra instability: half the stiffness is enough), 1/c for damping alone."""
    w2 = w_verlet2 + 2.0 * w_explicit2
    if w2 <= 0.0:
        return 1.0 / c if c > 0 else math.inf
    return 2.0 * (math.sqrt(c * c + w2) - c) / w2  # no cancellation: c^2 << W^2 in practice


def _pair_kinds(scene: Scene) -> list[tuple[float, float, int]]:
    """(radius m, mass kg, count) of each kind of free disk."""
    if scene.particles is not None or any(s.distributed for s in scene.species):
        d, m = ((scene.particles.diameter, scene.particles.mass) if scene.particles is not None
                else all_disks(scene))
        rows = np.column_stack([0.5 * np.asarray(d, float), np.asarray(m, float)])
        kinds, counts = np.unique(rows, axis=0, return_counts=True)
        return [(float(a), float(m), int(c)) for (a, m), c in zip(kinds, counts)]
    return [(0.5 * s.diameter, s.mass, s.count) for s in scene.species if s.count > 0]


def _rolling_pair(scene: Scene, kinds: list[tuple[float, float, int]]) -> float:
    """omega^2 (1/s^2) of the stiffest rolling pair over k_r: a'^2 (1/I_i + 1/I_j) with the
    reduced radius a' = a_i a_j/(a_i + a_j) and I = m a^2/2."""
    if len(kinds) > 64:  # many kinds of free disk: a cruder bound, a'^2 (...) <= 2/min(m)
        return 2.0 / min(m for _, m, _ in kinds)
    return max((((ai * aj / (ai + aj)) ** 2) * 2.0 * (1 / (mi * ai**2) + 1 / (mj * aj**2))
                for i, (ai, mi, ni) in enumerate(kinds)
                for j, (aj, mj, _) in enumerate(kinds) if i != j or ni >= 2), default=0.0)


def contact_modes(scene: Scene) -> list[tuple[str, float]]:
    """(what, largest admitted step in s) of the resolution rule and of each mode the scene's
    effects enable. The modes are the stiffest of the densest packing (hexagonal, six contacts
    per disk) of the lightest disks, m_red the lightest pair's reduced mass; a partner of
    infinite mass (a ring, a wall disk) gives a contact a smaller omega^2 than a free partner
    (k/m_i against k/m_red), except the rolling spring on a flat ring surface (below). Each
    step is ``mode_step_limit`` of the mode:

    translation   every spring that pushes centres: k_n, and the sticking tangential spring
                  k_t (with or without rotation: it acts on the centres either way), which is
                  incremented explicitly. Rayleigh: a disk's stiffness sum_c (k_n n n + k_t
                  t t) has at most 3 (k_n + k_t) with six neighbours 60 degrees apart, and
                  each partner moves too: omega^2 <= 3 (k_n + k_t)/m_red (the hexagonal
                  packing's M point attains 3 k_n/m_red exactly), so W^2 = 3 (k_n + 2 k_t)/
                  m_red; damping 3 (gamma_n + gamma_t)/m_red, which grows with the stiffness:
                  zeta = 0.75 against the pair's 0.43 for the paper's material.
    gears         rotation with friction: every disk turning alike, each of the six contacts
                  slips by 2 a theta: omega^2 = 4 z k_t/m = 12 k_t/m_red, four times the
                  pair's 3 k_t/m_red; damping 12 gamma_t/m_red. Without rotation this mode
                  does not exist, and the tangential spring is in ``translation`` only.
    rolling       the rolling spring on the relative rotation: Rayleigh, each contact adds at
                  most its pair's k_r a'^2 (1/I_i + 1/I_j) to a disk, six of them; a contact
                  with a flat ring surface adds 2 k_r/m_i (a' = a_i, the ring does not turn)
                  and leaves room for four neighbours.
    With pair tables each stiffness and damping is the largest of the laws in use, with the
    lightest pair's m_red: a bound for any mix of pairs.
    """
    e = scene.effects
    m_red = smallest_reduced_mass(scene)
    t_c = smallest_contact_time(scene)
    z = PACKING_CONTACTS
    modes = [(f"a collision's resolution, {STEPS_PER_CONTACT:g} steps per contact time t_c",
              t_c / STEPS_PER_CONTACT)]
    laws = [(x, *normal_stiffness(scene, x)[1:]) for x in contact_laws(scene)]
    k_n = max(k for _, k, _ in laws)  # the stiffest of each: a bound for any mix of pairs
    sticking = [(x, k) for x, _, k in laws if k > 0 and x.mu > 0]  # mu = 0: it never sticks
    friction = e.tangential_friction and bool(sticking)
    gamma_t = (max(tangential_gamma(x, k, m_red) for x, k in sticking)
               if friction and e.tangential_damping else 0.0)
    gamma_n = max(contact_gamma(x, k, m_red) for x, k, _ in laws) if e.normal_damping else 0.0
    k_t = max(k for _, k in sticking) if friction else 0.0
    damp = z / 2 * (gamma_n + gamma_t) / m_red
    what = "the densest packing's translation, omega^2 = 3 k_n/m_red"
    what += " + 3 k_t/m_red (explicit spring)" if friction else ""
    what += f", damped by {z // 2} gamma/m_red" if damp > 0 else ""
    modes.append((what, mode_step_limit(z / 2 * k_n / m_red, z / 2 * k_t / m_red, damp)))
    if friction and e.rotation:
        modes.append(("the densest packing's disks turning alike (gears), omega^2 = 12 k_t/m_red"
                      " (explicit spring)",
                      mode_step_limit(0.0, 2 * z * k_t / m_red, 2 * z * gamma_t / m_red)))
    k_r = max(x.k_r for x, _, _ in laws)
    if e.rolling_resistance and e.rotation and k_r > 0:
        kinds = _pair_kinds(scene)
        pair = _rolling_pair(scene, kinds)
        w2 = z * pair
        if scene.geometry is not None:  # a disk on a ring surface, four neighbours beside it
            w2 = max(w2, 2.0 / min(m for _, m, _ in kinds) + (z - 2) * pair)
        modes.append(("the rolling spring, omega^2 = 6 k_r a'^2 (1/I_i + 1/I_j) (explicit "
                      "spring)", mode_step_limit(0.0, k_r * w2, 0.0)))
    return modes


def stability_limit(scene: Scene) -> tuple[float, str]:
    """The largest admitted step (s), the smallest of ``contact_modes``, and its mode."""
    what, step = min(contact_modes(scene), key=lambda m: m[1])
    return step, what


def rounded(x: float, digits: int, down: bool) -> str:
    """``x`` to ``digits`` significant digits, rounded down (or up) rather than to the nearest:
    a bound printed this way holds as printed, so that copying a printed limit into a scene
    is accepted (the nearest rounding of 0.00019629 s is 0.0001963 s, above it)."""
    if not math.isfinite(x) or x == 0.0:
        return f"{x:g}"
    exact = Decimal(x)  # the float's own value, no rounding yet
    grid = Decimal(1).scaleb(exact.adjusted() - digits + 1)
    return f"{float(exact.quantize(grid, ROUND_FLOOR if down else ROUND_CEILING)):.{digits}g}"

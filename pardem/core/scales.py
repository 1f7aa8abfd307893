"""The scales of a scene's contacts: its lightest pair, its kinds of free disk, the normal
law's linear stiffness and the contact time t_c of the damped normal spring (SPEC §3), from
which the time step (timestep.py) and the stable step (stability.py) follow. Units SI: N/m,
kg/s, kg, s.
"""

from __future__ import annotations

import math

import numpy as np

from ..contact import damped_spring
from ..contact.damped_spring import contact_gamma, restitution_beta
from ..contact.normal import law_of
from ..contact.pairs import harmonic, own_contacts, pair_contacts, species_count
from ..input.scene import Scene, SceneError
from ..input.species import all_disks, representative_disks, species_disks


def contact_time(k_n: float, gamma_n: float, m_red: float) -> float:
    """t_c (s) of the damped normal spring; SceneError when the contact is overdamped."""
    try:
        return damped_spring.contact_time(k_n, gamma_n, m_red)
    except ValueError as e:
        raise SceneError(f"[contact] gamma_n = {gamma_n!r}: {e} for reduced mass {m_red:.4g} "
                         "kg; a contact never ends, so there is no t_c (kg/s)") from None


def smallest_reduced_mass(scene: Scene) -> float:
    """Smallest reduced mass (kg) over pairs of free particles: that of the two lightest ones.

    A lighter partner always lowers m_red, so the two lightest particles decide; one particle of a
    species cannot pair with itself. With a single free particle the only partners are walls
    (infinitely massive), so m_red = m.
    """
    # a couette scene's disks as placed: a distribution's lightest drawn disks decide
    m = np.asarray(scene.particles.mass) if scene.particles is not None else all_disks(scene)[1]
    if m.size == 1:
        return float(m[0])
    a, b = _two_lightest(m)
    return float(a * b / (a + b))


def _two_lightest(m: np.ndarray) -> np.ndarray:
    """The (at most) two smallest of the masses ``m``, ascending."""
    return np.sort(np.partition(m, 1)[:2] if m.size > 2 else m)


def normal_stiffness(scene: Scene, c=None) -> tuple[float, float, float]:
    """(k_load, k_elastic, k_t) N/m: the linear stiffnesses of the scene's contact law (or of
    the [contact] table ``c``, a pair's: contact.pairs.contact_laws) at its reference overlap
    of the largest free disk (contact.normal.NormalLaw.stiffness; k_n, k_n, k_t for the
    linear law). k_load sets how deep an impact goes, k_elastic (the stiffer, reversible
    branch) the contact time and the stable step; the averaging's k'_n is the [contact]
    law's k_elastic, whatever the pair tables say."""
    c = scene.contact if c is None else c
    return law_of(c).stiffness(c, max(d for d, _ in free_disks(scene)))


def smallest_contact_time(scene: Scene) -> float:
    """t_c (s) of the pair with the smallest reduced mass under the [contact] law, or of any
    pair of partners if shorter (its table's law, or its mixed law: contact/pairs.py; with its
    own reduced mass, a ring infinitely massive); the damping counts only if the scene
    switches normal damping on (a restitution gives each pair's gamma_n from its m_red)."""
    damped = scene.effects.normal_damping

    def time(k, gamma, m_red):
        return contact_time(k, gamma if damped else 0.0, m_red)

    k = normal_stiffness(scene)[1]
    m_red = smallest_reduced_mass(scene)
    t_c = time(k, contact_gamma(scene.contact, k, m_red), m_red)
    if not scene.pairs:
        return t_c
    given, own = dict(pair_contacts(scene)), own_contacts(scene)
    for p in range(len(own)):
        for q in range(p, len(own)):
            m_red = pair_reduced_mass(scene, p, q)
            if m_red is None:
                continue
            if (p, q) in given:
                k = normal_stiffness(scene, given[p, q])[1]
                gamma = contact_gamma(given[p, q], k, m_red)
            else:  # the mixed law's stiffness at the reference overlap mixes alike
                k = harmonic(normal_stiffness(scene, own[p])[1],
                             normal_stiffness(scene, own[q])[1])
                gamma = mixed_gamma(own[p], own[q], k, m_red)
            t_c = min(t_c, time(k, gamma, m_red))
    return t_c


def mixed_gamma(a, b, k: float, m_red: float) -> float:
    """gamma_n (kg/s) of the mix of two own [contact] tables (contact/pairs.py's rule) for a
    contact of stiffness k and reduced mass m_red."""
    if a.restitution is None:
        return harmonic(a.gamma_n, b.gamma_n)
    return restitution_beta(math.sqrt(a.restitution * b.restitution)) * math.sqrt(k * m_red)


def pair_reduced_mass(scene: Scene, p: int, q: int) -> float | None:
    """The smallest reduced mass (kg) of a contact between partners p <= q (contact/pairs.py;
    a ring is infinitely massive), None if the scene has no such contact."""
    if scene.particles is not None:  # partners past the species: file wall disks, fixed
        s, m = np.asarray(scene.particles.species), np.asarray(scene.particles.mass)
        lightest = [_two_lightest(m[s == k]) if k < species_count(scene) else None
                    for k in (p, q)]
    else:
        lightest = [_two_lightest(representative_disks(scene)[k][1]) if k < len(scene.species)
                    else None for k in (p, q)]
    a, b = lightest
    if a is None:  # two rings never touch
        return None
    if b is None:  # a ring
        return float(a[0]) if a.size else None
    if p == q:
        return float(a[0] * a[1] / (a[0] + a[1])) if a.size == 2 else None
    return float(a[0] * b[0] / (a[0] + b[0])) if a.size and b.size else None


def free_disks(scene: Scene) -> list[tuple[float, float]]:
    """(diameter m, mass kg) of every kind of free disk in the scene."""
    if scene.particles is not None:
        return list(zip(np.asarray(scene.particles.diameter, float),
                        np.asarray(scene.particles.mass, float)))
    kinds: list[tuple[float, float]] = []
    for s, (d, m) in zip(scene.species, species_disks(scene)):
        if s.count > 0:  # a distribution: each drawn disk its own kind
            kinds += zip(d.tolist(), m.tolist()) if s.distributed else [(s.diameter, s.mass)]
    return kinds

"""The scales of a scene's contacts: its lightest pair, its kinds of free disk, the normal
law's linear stiffness and the contact time t_c of the damped normal spring (SPEC §3), from
which the time step (timestep.py) and the stable step (stability.py) follow. Units SI: N/m,
kg/s, kg, s.
"""

from __future__ import annotations

import numpy as np

from ..contact import model
from ..contact.normal import law_of
from ..input.scene import Scene, SceneError


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


def normal_stiffness(scene: Scene) -> tuple[float, float, float]:
    """(k_load, k_elastic, k_t) N/m: the linear stiffnesses of the scene's contact law at its
    reference overlap of the largest free disk (contact.normal.NormalLaw.stiffness; k_n, k_n,
    k_t for the linear law). k_load sets how deep an impact goes, k_elastic (the stiffer,
    reversible branch) the contact time, the stable step and the averaging's k'_n."""
    c = scene.contact
    return law_of(c).stiffness(c, max(d for d, _ in free_disks(scene)))


def smallest_contact_time(scene: Scene) -> float:
    """t_c (s) of the pair with the smallest reduced mass; gamma_n counts only if the scene
    switches normal damping on."""
    c = scene.contact
    gamma = c.gamma_n if scene.effects.normal_damping else 0.0
    return contact_time(normal_stiffness(scene)[1], gamma, smallest_reduced_mass(scene))


def free_disks(scene: Scene) -> list[tuple[float, float]]:
    """(diameter m, mass kg) of every kind of free disk in the scene."""
    if scene.particles is not None:
        return list(zip(np.asarray(scene.particles.diameter, float),
                        np.asarray(scene.particles.mass, float)))
    return [(s.diameter, s.mass) for s in scene.species if s.count > 0]

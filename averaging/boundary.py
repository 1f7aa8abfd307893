"""Loads on the rings from the contact tables: the torque the inner ring exerts on the particles.

Stage: averaging (validation). In steady shear the torque passed outwards through every ring,
T(r) = 2 pi h r^2 sigma_rphi (sigma with compression positive), is the same for all r and
equals the torque the inner ring exerts on the particles, summed here from the ring's contacts
with the free particles (wall-disk contacts and flat-surface contacts, each force acting at
the contact point). Both are recorded with every averaging sample (``RingAverager``).
"""

from __future__ import annotations

import numpy as np

from pardem.sampling import INNER_WALL


def inner_ring_torque(particles: dict, contacts: dict, ring_contacts: dict | None) -> float:
    """Torque (N m, about the axis, counter-clockwise positive) of the inner ring on the free
    particles, from a snapshot's arrays (rows sorted by id)."""
    on_ring = particles["kind"][contacts["ids"][:, 1]] == INNER_WALL  # hi: the wall disk
    torque = _torque_on_particles(particles, contacts["ids"][on_ring, 0],
                              {k: v[on_ring] for k, v in contacts.items()})
    if ring_contacts is not None:
        sel = ring_contacts["ring"] == 1
        torque += _torque_on_particles(particles, ring_contacts["id"][sel],
                                   {k: v[sel] for k, v in ring_contacts.items()})
    return torque


def _torque_on_particles(particles: dict, p: np.ndarray, t: dict) -> float:
    f_on_p = t["normal_force"][:, None] * t["normal"] + t["tangential_force"]
    return torque_on(particles["position"][p], particles["radius"][p], t["normal"],
                     t["overlap"], f_on_p)


def torque_on(x: np.ndarray, radius: np.ndarray, normal: np.ndarray, overlap: np.ndarray,
              force: np.ndarray) -> float:
    """Torque about the axis (N m) of contact forces ``force`` [m,2] on particles at x [m,2],
    each acting at the contact point x - (a - delta/2) n (n from the partner to the particle)."""
    xc = x - (radius - 0.5 * overlap)[:, None] * normal
    return float(np.sum(xc[:, 0] * force[:, 1] - xc[:, 1] * force[:, 0]))

"""Loads on the rings from the contact tables: the torque the particles exert on the inner ring.

Stage: averaging (validation). In steady shear the torque passed through every ring is the
same, T = -2 pi h r^2 sigma_rphi (sigma with compression positive), and equals the torque on
the inner ring, summed here from its contacts with the free particles: wall-disk contacts and
flat-surface contacts, each force acting at the contact point.
"""

from __future__ import annotations

import numpy as np

from pardem.state import INNER_WALL


def inner_ring_torque(particles: dict, contacts: dict, ring_contacts: dict | None) -> float:
    """Torque (N m, about the axis, counter-clockwise positive) of the free particles on the
    inner ring, from a snapshot's arrays (rows sorted by id)."""
    on_ring = particles["kind"][contacts["ids"][:, 1]] == INNER_WALL  # hi: the wall disk
    torque = _reaction_torque(particles, contacts["ids"][on_ring, 0],
                              {k: v[on_ring] for k, v in contacts.items()})
    if ring_contacts is not None:
        sel = ring_contacts["ring"] == 1
        torque += _reaction_torque(particles, ring_contacts["id"][sel],
                                   {k: v[sel] for k, v in ring_contacts.items()})
    return torque


def _reaction_torque(particles: dict, p: np.ndarray, t: dict) -> float:
    """Torque about the axis of the reactions -f of contacts t on particles p, each acting at
    the contact point x_p - (a_p - delta/2) n."""
    n, d = t["normal"], t["overlap"]
    f_on_p = t["normal_force"][:, None] * n + t["tangential_force"]
    xc = particles["position"][p] - (particles["radius"][p] - 0.5 * d)[:, None] * n
    return float(-np.sum(xc[:, 0] * f_on_p[:, 1] - xc[:, 1] * f_on_p[:, 0]))

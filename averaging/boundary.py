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
    x, a, kind = particles["position"], particles["radius"], particles["kind"]
    ids = contacts["ids"]
    on_ring = kind[ids[:, 1]] == INNER_WALL  # lo is the free particle, hi the wall disk
    p = ids[on_ring, 0]
    n, d = contacts["normal"][on_ring], contacts["overlap"][on_ring]
    f_on_p = contacts["normal_force"][on_ring, None] * n + contacts["tangential_force"][on_ring]
    xc = x[p] - (a[p] - 0.5 * d)[:, None] * n
    torque = -np.sum(xc[:, 0] * f_on_p[:, 1] - xc[:, 1] * f_on_p[:, 0])
    if ring_contacts is not None:
        sel = ring_contacts["ring"] == 1
        q = ring_contacts["id"][sel]
        n, d = ring_contacts["normal"][sel], ring_contacts["overlap"][sel]
        f_on_p = ring_contacts["normal_force"][sel, None] * n + \
            ring_contacts["tangential_force"][sel]
        xc = x[q] - (a[q] - 0.5 * d)[:, None] * n
        torque -= np.sum(xc[:, 0] * f_on_p[:, 1] - xc[:, 1] * f_on_p[:, 0])
    return float(torque)

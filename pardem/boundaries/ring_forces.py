"""Contacts of free disks with the two flat ring surfaces (infinitely massive walls).

Stage: forces (called by forces.contact_forces inside the step loop).
"""

from __future__ import annotations

import numba as nb

from ..contact.damping import with_damping
from ..contact.model import history_width, surface_contact
from ..contact.overlap import MAX_OVERLAP
from ..contact.overlap import note_deep
from ..contact.pairs import pair_law, ring_partner
from ..core.jit import JIT
from .walls import outer_radius, ring_surface, surface_motion


@nb.njit(**JIT)
def ring_contacts(ps, pairs, prm, t, reach, o, rotation, record, deep):
    """Contacts of candidate free particles with the two flat ring surfaces (infinitely
    massive; walls.ring_surface gives the geometry and the surface's motion); an overlap
    beyond MAX_OVERLAP of the disk's diameter is noted in ``deep`` (ForceWork.deep)."""
    has_hist = history_width(o) > 0
    r_o, r_o_dot = outer_radius(t, prm.rings)
    lim = reach if o.damping and o.window else 0.0
    for q in range(pairs.wall_count[0]):
        i = pairs.wall[q]
        a = ps.radius[i]
        hit = ring_surface(ps.x[i, 0], ps.x[i, 1], a, lim, r_o, prm.rings)
        ring, nx, ny, delta = hit
        if ring == 0:
            if has_hist:
                ps.hist_wall[i, :] = 0.0
            if record:
                pairs.wall_fn[q] = 0.0
                pairs.wall_ft[q, 0] = 0.0
                pairs.wall_ft[q, 1] = 0.0
            continue
        vjx, vjy, s_j, w_j = surface_motion(hit, r_o_dot, prm.rings)
        if delta > 2.0 * MAX_OVERLAP * a:
            note_deep(deep, float(i), delta, 2.0 * a, float(ring))
        w_i = ps.w_pred[i] if rotation else 0.0
        s = (a * ps.w_pred[i] if rotation else 0.0) + s_j
        fn, ftx, fty, torque = surface_contact(
            (nx, ny), delta, a, (ps.v_pred[i, 0] - vjx + s * ny, ps.v_pred[i, 1] - vjy - s * nx),
            (w_i, w_j), ps.hist_wall, i,
            with_damping(pair_law(prm.pair_law, ps.species[i], ring_partner(prm.pair_law, ring),
                                  prm.law, o), 1.0 / ps.inv_mass[i], o), o)
        if record:
            pairs.wall_fn[q] = fn
            pairs.wall_ft[q, 0] = ftx
            pairs.wall_ft[q, 1] = fty
        ps.f[i, 0] += fn * nx + ftx
        ps.f[i, 1] += fn * ny + fty
        if rotation:
            ps.tau[i] += torque

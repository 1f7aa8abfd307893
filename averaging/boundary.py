"""Loads on the rings from the contact tables: the torque each ring exerts on the particles,
the force the particles exert on each ring and their radial push on it.

Stage: averaging (validation). In steady shear the torque passed outwards through every ring,
T(r) = 2 pi h r^2 sigma_rphi (sigma with compression positive), is the same for all r and
equals the torque the inner ring exerts on the particles; the outer ring takes it back:
T_in + T_out + T_bottom = dL/dt (T_bottom the bottom friction's torque on the disks, L their
angular momentum). The loads are summed from each ring's contacts with the free particles
(wall-disk contacts and flat-surface contacts, each force acting at the contact point) and
recorded with every averaging sample (``RingAverager``).

Rank independence: every contact's share (``load_rows``) is computed from that contact's
own positions and forces, which do not depend on the number of ranks, and the shares are
added by ``math.fsum``, correctly rounded and so independent of their order: the same bits
on any number of ranks, in situ and from snapshots. Rolling-resistance couples of ring
contacts are not in the torques (the tables do not carry the rolling force).
"""

from __future__ import annotations

import math

import numpy as np

from pardem.sampling import INNER_WALL, OUTER_WALL

LOADS = ("inner_torque", "inner_force_x", "inner_force_y", "inner_radial_force",
         "outer_torque", "outer_force_x", "outer_force_y", "outer_radial_force")
"""The ring loads of a sample, in this order (``load_rows`` columns)."""

LOAD_UNITS = {name: "N m" if name.endswith("torque") else "N" for name in LOADS}

LOAD_DESCRIPTIONS = {
    "inner_torque": "torque of the inner ring on the particles (counter-clockwise positive)",
    "outer_torque": "torque of the outer ring on the particles (counter-clockwise positive)",
    **{f"{ring}_force_{c}": f"force of the particles on the {ring} ring, {c} component"
       for ring in ("inner", "outer") for c in "xy"},
    "inner_radial_force": "radial push of the particles on the inner ring (inwards positive)",
    "outer_radial_force": "radial push of the particles on the outer ring (outwards positive)"}


def load_rows(x: np.ndarray, radius: np.ndarray, normal: np.ndarray, overlap: np.ndarray,
              force: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """Each ring contact's share [m, len(LOADS)] of the loads: particle centres x [m,2] (m),
    radii [m] (m), normals [m,2] (unit, from the ring's disk or surface to the particle),
    overlaps [m] (m), forces on the particles [m,2] (N), ``ring`` [m] (1 inner, 2 outer).
    The force acts at the contact point x - (a - delta/2) n."""
    xc = x - (radius - 0.5 * overlap)[:, None] * normal
    on_ring = -force
    r = np.hypot(xc[:, 0], xc[:, 1])
    outward = (on_ring[:, 0] * xc[:, 0] + on_ring[:, 1] * xc[:, 1]) / r
    rows = np.zeros((radius.size, len(LOADS)))
    for which, push in ((1, -1.0), (2, 1.0)):
        sel = ring == which
        c = 4 * (which - 1)
        rows[sel, c] = xc[sel, 0] * force[sel, 1] - xc[sel, 1] * force[sel, 0]
        rows[sel, c + 1:c + 3] = on_ring[sel]
        rows[sel, c + 3] = push * outward[sel]
    return rows


def total_loads(rows: np.ndarray) -> np.ndarray:
    """The loads [len(LOADS)] from every contact's share (all ranks' rows): each column
    correctly rounded (``math.fsum``), whatever the order of the rows."""
    return np.array([math.fsum(rows[:, k]) for k in range(len(LOADS))])


def pair_rows(x: np.ndarray, radius: np.ndarray, kind: np.ndarray, table: dict,
              lo: np.ndarray, hi: np.ndarray, free: np.ndarray) -> np.ndarray:
    """``load_rows`` of the touching pairs in ``table`` (a contact table: normal from hi to
    lo, forces on lo) between a free particle lo where ``free`` and a ring's wall disk hi (a
    wall disk always has the higher gid); x, radius, kind indexed by lo and hi."""
    wall = kind[hi]
    on = free & ((wall == INNER_WALL) | (wall == OUTER_WALL))
    p = lo[on]
    f = table["normal_force"][on, None] * table["normal"][on] + table["tangential_force"][on]
    return load_rows(x[p], radius[p], table["normal"][on], table["overlap"][on], f,
                     np.where(wall[on] == INNER_WALL, 1, 2))


def surface_rows(x: np.ndarray, radius: np.ndarray, table: dict | None,
                 particle: np.ndarray | None) -> np.ndarray:
    """``load_rows`` of the contacts with the flat ring surfaces (a ring contact table, its
    particles' rows ``particle``; none without the table)."""
    if table is None:
        return np.zeros((0, len(LOADS)))
    f = table["normal_force"][:, None] * table["normal"] + table["tangential_force"]
    return load_rows(x[particle], radius[particle], table["normal"], table["overlap"], f,
                     table["ring"])


def snapshot_rows(particles: dict, contacts: dict, ring_contacts: dict | None) -> np.ndarray:
    """Every ring contact's share of the loads from a snapshot's arrays (rows sorted by id,
    so a particle's row is its id)."""
    x, radius = particles["position"], particles["radius"]
    lo, hi = contacts["ids"][:, 0], contacts["ids"][:, 1]
    return np.vstack([
        pair_rows(x, radius, particles["kind"], contacts, lo, hi, np.ones(lo.size, bool)),
        surface_rows(x, radius, ring_contacts,
                     None if ring_contacts is None else ring_contacts["id"])])


def ring_loads(particles: dict, contacts: dict, ring_contacts: dict | None) -> dict:
    """The loads (LOADS -> value, SI) on the rings from a snapshot's arrays."""
    return dict(zip(LOADS, total_loads(snapshot_rows(particles, contacts, ring_contacts))))


def inner_ring_torque(particles: dict, contacts: dict, ring_contacts: dict | None) -> float:
    """Torque (N m, about the axis, counter-clockwise positive) of the inner ring on the free
    particles, from a snapshot's arrays (rows sorted by id)."""
    return float(ring_loads(particles, contacts, ring_contacts)["inner_torque"])


def torque_balance(loads: dict, r_in: float, r_out: float, height: float) -> dict:
    """The torque balance of time-averaged ``loads`` (LOADS -> value): ``torque_sum`` =
    T_in + T_out (N m; in steady shear the bottom friction's torque plus dL/dt, 0 without
    bottom friction), ``torque_imbalance`` = (T_in + T_out)/T_in, and the shear stress each
    ring's torque implies at its radius, ``wall_shear_stress_inner`` = T_in/(2 pi h R_i^2),
    ``wall_shear_stress_outer`` = -T_out/(2 pi h R_o^2) (Pa; R^2 sigma equal in balance)."""
    t_in, t_out = float(loads["inner_torque"]), float(loads["outer_torque"])
    with np.errstate(invalid="ignore", divide="ignore"):
        imbalance = np.float64(t_in + t_out) / np.float64(t_in)
    return {"torque_sum": t_in + t_out, "torque_imbalance": float(imbalance),
            "wall_shear_stress_inner": t_in / (2 * math.pi * height * r_in**2),
            "wall_shear_stress_outer": -t_out / (2 * math.pi * height * r_out**2)}


def summary(loads: dict, r_in: float, r_out: float, height: float, samples: int) -> str:
    """One log line: the time-averaged ring loads and their torque balance."""
    b = torque_balance(loads, r_in, r_out, height)
    return (f"ring loads over {samples} samples: torque on the particles of the inner ring "
            f"{loads['inner_torque']:.6g} N m, of the outer ring {loads['outer_torque']:.6g} "
            f"N m, sum {b['torque_sum']:.6g} N m ({100 * b['torque_imbalance']:.3g} % of the "
            f"inner; bottom friction and dL/dt take the rest); wall shear stress "
            f"{b['wall_shear_stress_inner']:.6g} Pa inner, {b['wall_shear_stress_outer']:.6g} "
            f"Pa outer; radial push {loads['inner_radial_force']:.6g} N on the inner ring, "
            f"{loads['outer_radial_force']:.6g} N on the outer")

"""One sample's input to the ring sums: free particles and their contacts, each contact seen
from the particle (normal towards it, force on it, tangential displacement in its
orientation), from a running Simulation (this rank's owned particles, ``sample_simulation``)
or from a snapshot (the whole cell, ``snapshot_sample``): the same rows either way, so in-situ
and offline averages agree to round-off.

Stage: averaging. Disk-disk contacts count for each free partner; contacts with wall disks and
with the flat ring surfaces count for the free particle only (SPEC §4). Per particle, contacts
keep the pair list's canonical order, so a particle's sum is the same on any number of ranks.
Forces are the ones the step applied (Simulation.local_view; the snapshots store the same).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pardem.sampling import SceneError

from .boundary import LOADS, pair_rows, snapshot_rows, surface_rows


class Sample(NamedTuple):
    """Particles x [n,2] (m), v [n,2] (m/s), omega [n] (rad/s), radius [n] (m), mass [n] (kg);
    contacts of particle p in rows start[p]:start[p+1] of normal [m,2], overlap [m] (m),
    force [m,2] (N, on p), tangential [m,2] (m: the contact's tangential history t, so that the
    contact displacement is Delta = delta n - t; the elastic spring xi by default, the total
    tangential displacement eta of eq. 1.3 with [averaging] displacement = "eta"); wall_rows
    [k, len(boundary.LOADS)]: the shares of these particles' ring contacts in the loads on
    the rings (boundary.load_rows; added over all ranks by boundary.total_loads)."""

    x: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    radius: np.ndarray
    mass: np.ndarray
    start: np.ndarray
    normal: np.ndarray
    overlap: np.ndarray
    force: np.ndarray
    tangential: np.ndarray
    wall_rows: np.ndarray

    @property
    def particles(self) -> tuple:
        """(x, v, omega, radius, mass): sums.accumulate's particle argument."""
        return self.x, self.v, self.omega, self.radius, self.mass

    @property
    def contacts(self) -> tuple:
        """(start, normal, overlap, force, tangential): sums.accumulate's contact argument."""
        return self.start, self.normal, self.overlap, self.force, self.tangential


def empty_sample() -> Sample:
    """A sample without particles or contacts, with the array types of every other (what
    ``pardem.compile_ahead`` compiles the ring sums for)."""
    rows, pairs = np.zeros(0), np.zeros((0, 2))
    return from_contacts(pairs, pairs, rows, rows, rows, np.zeros(0, np.int64), pairs, rows,
                         pairs, pairs)


def from_contacts(x, v, omega, radius, mass, owner, normal, overlap, force, tangential,
                  wall_rows: np.ndarray | None = None) -> Sample:
    """Build a Sample from per-contact rows already oriented towards ``owner`` (particle
    index); ``wall_rows``: the ring contacts' shares of the ring loads (default: none)."""
    if wall_rows is None:
        wall_rows = np.zeros((0, len(LOADS)))
    order = np.argsort(owner, kind="stable")
    start = np.zeros(radius.size + 1, np.int64)
    np.cumsum(np.bincount(owner, minlength=radius.size), out=start[1:])
    return Sample(x, v, omega, radius, mass, start, normal[order], overlap[order],
                  force[order], tangential[order], wall_rows)


DISPLACEMENTS = {"eta": "displacement", "spring": "spring"}
"""[averaging] displacement -> the contact-table column that gives the tangential part of Delta."""


def oriented_rows(i, j, as_i, as_j, pairs: dict, ring_owner=None, ring: dict | None = None,
                  displacement: str = "spring"):
    """Per-contact rows ``(owner, normal, overlap, force, tangential)`` seen from each particle
    that gets a share: a pair table's row counts for i where ``as_i`` and, negated, for j where
    ``as_j``; ring-contact rows count for ``ring_owner``. Force = normal_force n + tangential
    force; tangential: the table's eta or spring column (``displacement``; a table with
    neither, from a run without tangential friction, gives zeros)."""
    def force(t):
        return t["normal_force"][:, None] * t["normal"] + t["tangential_force"]

    def tangential(t):
        key = DISPLACEMENTS[displacement]
        if key in t:
            return t[key]
        if np.any(t["spring"]):
            raise ValueError(f"contacts have no {key!r} column (eta is tracked only in runs "
                             "with tangential friction that write contacts or average with "
                             'displacement = "eta"); average with displacement = "spring"')
        return np.zeros_like(t["spring"])

    f = force(pairs)
    t = tangential(pairs)
    parts = [(i[as_i], pairs["normal"][as_i], pairs["overlap"][as_i], f[as_i], t[as_i]),
             (j[as_j], -pairs["normal"][as_j], pairs["overlap"][as_j], -f[as_j], -t[as_j])]
    if ring is not None:
        parts.append((ring_owner, ring["normal"], ring["overlap"], force(ring), tangential(ring)))
    owner, normal, overlap, force_, tang = (np.concatenate(c) for c in zip(*parts))
    return owner.astype(np.int64), normal, overlap, force_, tang


def sample_simulation(sim) -> Sample:
    """This rank's sample of a running Simulation: its owned particles and every touching
    contact with an owned partner, with the forces the last step applied."""
    rows, n_owned, tables = sim.local_view()
    t, ring = tables.pairs, tables.rings
    i, j = t["index"][:, 0], t["index"][:, 1]
    cfg = sim.scene.averaging
    owner, normal, overlap, force, tangential = oriented_rows(
        i, j, i < n_owned, j < n_owned, t, None if ring is None else ring["index"], ring,
        cfg.displacement if cfg is not None else "spring")
    sl = slice(0, n_owned)
    return from_contacts(rows["x"][sl], rows["v"][sl], rows["omega"][sl], rows["radius"][sl],
                         rows["mass"][sl], owner, normal, overlap, force, tangential,
                         _wall_rows(rows, t, i, j, n_owned, ring))


def _wall_rows(rows: dict, t: dict, i, j, n_owned: int, ring: dict | None) -> np.ndarray:
    """The ring contacts' shares of the ring loads for this rank's particles: their contacts
    with wall disks and with the flat ring surfaces."""
    x, radius = rows["x"], rows["radius"]
    return np.vstack([pair_rows(x, radius, rows["kind"], t, i, j, i < n_owned),
                      surface_rows(x, radius, ring, None if ring is None else ring["index"])])


def snapshot_sample(snap: dict, displacement: str = "spring") -> Sample:
    """The free particles of a snapshot (rows sorted by id, so a free particle's row is its id)
    and their contacts, oriented towards each free partner; ``displacement``: "eta" or "spring"
    for the tangential part of Delta (``oriented_rows``)."""
    if "contacts" not in snap:
        raise SceneError(f"snapshot at t = {snap['time']} s has no contacts: offline averaging "
                         "needs [output] contacts = true")
    free = snap["kind"] == 0
    n = int(free.sum())
    c = snap["contacts"]
    lo, hi = c["ids"][:, 0], c["ids"][:, 1]
    ring = snap.get("ring_contacts")
    # lo is always free; free ids are 0..n-1, wall disks come after
    try:
        owner, normal, overlap, force, tangential = oriented_rows(
            lo, hi, np.ones(lo.size, bool), hi < n, c, None if ring is None else ring["id"],
            ring, displacement)
    except ValueError as e:
        raise SceneError(f"snapshot at t = {snap['time']} s: {e}") from None
    return from_contacts(snap["position"][:n], snap["velocity"][:n], snap["omega"][:n],
                         snap["radius"][:n], snap["mass"][:n], owner, normal, overlap, force,
                         tangential, snapshot_rows(snap, c, ring))

"""Read-only views of a Simulation's state: whole-cell arrays gathered on rank 0, this rank's
contact tables, energies and overlaps.

Stage: diagnostics and output (every method is collective under MPI; the gathered ones return
None on the other ranks). Contact forces are the ones the last step applied (diagnostics.py).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .core import diagnostics as diag
from .boundaries.walls import outer_radius


class LocalTables(NamedTuple):
    """This rank's contacts: ``pairs`` (diagnostics.contact_table) and ``rings``
    (diagnostics.ring_contact_table, None without rings)."""

    pairs: dict
    rings: dict | None


class StateViews:
    """Mixed into Simulation: the views of its state (``ps``, ``pairs``, ``clock``, ``prm``,
    ``decomp``, ``contact``)."""

    def kinetic_energy(self) -> float:
        """Translational + rotational kinetic energy (J) of the free particles."""
        return float(self.decomp.sum(diag.kinetic_energy(self.ps, int(self.clock.n_owned[0]))))

    def total_energy(self) -> float:
        """Kinetic + elastic energy (J): every spring of disk-disk and disk-ring contacts."""
        n_owned = int(self.clock.n_owned[0])
        e = diag.elastic_energy_pairs(self.ps, self.pairs, self.prm, self.contact, n_owned)
        if self.options.walls:
            e += diag.elastic_energy_rings(self.ps, self.pairs, self.prm, self.contact,
                                           outer_radius(self.clock_time, self.prm.rings)[0])
        return self.kinetic_energy() + float(self.decomp.sum(e))

    def max_overlap(self) -> float:
        """Largest overlap over the diameter of the smaller free particle in the contact."""
        r_out = outer_radius(self.clock_time, self.prm.rings)[0]
        return float(self.decomp.max(diag.max_overlap_ratio(self.ps, self.pairs, self.prm,
                                                            r_out)))

    def local_tables(self, n_own: int | None = None) -> LocalTables:
        """This rank's touching pairs whose lower-gid partner is among its first ``n_own`` rows
        (default: its owned particles, so each pair is reported once over the ranks; all local
        rows: every pair with an owned partner), with storage indices, and its ring contacts."""
        n_own = int(self.clock.n_owned[0]) if n_own is None else n_own
        pairs = diag.contact_table(self.ps, self.pairs, self.prm, self.contact, n_own,
                                   local_index=True)
        rings = None
        if self.options.walls:
            rings = diag.ring_contact_table(self.ps, self.pairs, self.prm, self.contact,
                                            outer_radius(self.clock_time, self.prm.rings)[0])
        return LocalTables(pairs, rings)

    def local_view(self):
        """What in-situ averaging needs of this rank: ``(particles, n_owned, tables)`` with
        the arrays of every local row (owned particles first: gid, kind, x, v, omega, radius,
        mass) and every touching pair with an owned partner (``local_tables``)."""
        ps, n = self.ps, int(self.clock.n_local[0] + self.clock.n_ghost[0])
        rows = {"gid": ps.gid[:n], "kind": ps.kind[:n], "x": ps.x[:n], "v": ps.v[:n],
                "omega": ps.omega[:n], "radius": ps.radius[:n], "mass": ps.mass[:n]}
        return rows, int(self.clock.n_owned[0]), self.local_tables(n)

    def contacts(self) -> dict[str, np.ndarray] | None:
        """Touching pairs of the whole cell sorted by id pair, on rank 0 (None on the others;
        collective): ``ids`` [M,2] (lower id first), ``normal`` [M,2] (unit, from the second
        to the first), ``overlap`` [M] (m), ``normal_force`` [M] (N), ``tangential_force``
        [M,2] (N, on the first), ``mobilised`` [M] (f_t / (mu f_n)), ``sliding`` [M] (1 at the
        Coulomb limit) and the contact history (e.g. ``spring`` [M,2], m), as the last step
        applied them (diagnostics.contact_table)."""
        t = self.local_tables().pairs
        del t["index"]
        return self.decomp.gather_rows(t, key="ids")

    def ring_contacts(self) -> dict[str, np.ndarray] | None:
        """Contacts of free particles with the flat ring surfaces, sorted by particle id, on
        rank 0 (None on the others, and without rings; collective): ``id``, ``ring`` (1 inner,
        2 outer), ``normal`` [M,2] (from the surface), ``overlap`` (m), ``normal_force`` (N),
        ``tangential_force`` [M,2] (N) and the contact history (diagnostics.ring_contact_table).
        """
        t = self.local_tables().rings
        if t is None:
            return None
        del t["index"]
        return self.decomp.gather_rows(t, key="id")

    PARTICLE_ARRAYS = {"id": "gid", "kind": "kind", "position": "x", "velocity": "v",
                       "omega": "omega", "theta": "theta", "radius": "radius", "mass": "mass",
                       "force": "f", "torque": "tau"}

    def gathered(self, *keys: str) -> dict[str, np.ndarray] | None:
        """Per-particle arrays of the whole cell sorted by id (rank 0; None on the others;
        collective): ``keys`` among PARTICLE_ARRAYS (SI units, as in the snapshots; default
        all) and ``rank`` (the owning rank, -1 for wall disks). Wall disks report zero force
        and torque: they are prescribed, and each rank adds only its own particles' contacts
        to them, so their loads are not a state."""
        ps, n_owned = self.ps, int(self.clock.n_owned[0])
        rows = slice(0, int(self.clock.n_local[0]) if self.decomp.rank == 0 else n_owned)
        keys = keys or (*self.PARTICLE_ARRAYS, "rank")
        mine = {"id": ps.gid[rows], "kind": ps.kind[rows]}
        mine.update({k: getattr(ps, self.PARTICLE_ARRAYS[k])[rows] for k in keys if k != "rank"})
        if "rank" in keys:
            mine["rank"] = np.full(mine["id"].size, self.decomp.rank, np.int32)
            mine["rank"][n_owned:] = -1
        out = self.decomp.gather_rows(mine, key="id")
        if out is not None:
            walls = out["kind"] != 0
            for k in ("force", "torque"):
                if k in out:
                    out[k][walls] = 0.0
        return out

    def particle_arrays(self) -> dict[str, np.ndarray] | None:
        """Particle data of the whole cell sorted by id (the snapshot layout); rank 0 only."""
        return self._particle_table(self.contacts())

    def _particle_table(self, contacts: dict[str, np.ndarray] | None):
        """particle_arrays() given this instant's gathered contacts (collective)."""
        out = self.gathered()
        if out is None:
            return None
        ids = contacts["ids"]
        out["coordination"] = np.bincount(np.searchsorted(out["id"], ids.ravel()),
                                          minlength=out["id"].size)
        return out

    def stats(self) -> dict:
        """This rank's counts: owned particles, ghosts, listed pairs, neighbour ranks, ghosts
        sent per step, whether the refresh needs an Allreduce, seconds spent waiting."""
        h = self.decomp.halo
        return {"owned": int(self.clock.n_owned[0]), "ghosts": int(self.clock.n_ghost[0]),
                "pairs": int(self.pairs.count[0]), "neighbours": 0 if h is None else
                int(h.nbr.size), "sent": 0 if h is None else int(h.send_idx.size),
                "allreduce": bool(h is not None and h.cfg.allreduce),
                "wait": float(self.decomp.wait[0])}

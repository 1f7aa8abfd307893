"""Force a particle with loaded contacts across a sector edge (2 ranks) and check its springs.

    mpiexec -n 2 python -m mpi4py tests/mpi/migrate_loaded.py SCENE SETTLE_STEPS AFTER_STEPS OUT.npz

After SETTLE_STEPS, picks the owned particle of rank 0 nearest to a sector edge that has at least
two touching contacts with non-zero springs, records the force, spring and torque of each of its
contacts as computed on *both* ranks, moves the edge just past the particle and rebuilds (the
particle migrates to rank 1 with its springs), records the same table again, then runs
AFTER_STEPS more and saves the gathered state (compared with a serial run by the test).
A failed check raises on the rank that finds it; ``python -m mpi4py`` then aborts every rank.
"""

import sys

import numpy as np
from mpi4py import MPI

from pardem import diagnostics as diag
from pardem.scene import load_scene
from pardem.simulation import Simulation


def contacts_of(sim, gid):
    """This rank's view of gid's touching contacts (every listed pair, owned or not); call
    sim.sync_ghost_velocities() (collective) first."""
    n_all = int(sim.clock.n_local[0] + sim.clock.n_ghost[0])
    t = diag.contact_table(sim.ps, sim.pairs, sim.prm, True, True, n_all)
    rows = np.flatnonzero((t["ids"] == gid).any(axis=1))
    return {k: v[rows] for k, v in t.items()}


def same_as_owner(table, full):
    """Every contact in this rank's table equals the owner's, bit for bit; at least one shown."""
    assert table["ids"].shape[0] >= 1
    rows = [int(np.flatnonzero((full["ids"] == pair).all(axis=1))[0]) for pair in table["ids"]]
    for k in full:
        assert np.array_equal(table[k], full[k][rows]), k


def main():
    scene, settle, after, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    comm = MPI.COMM_WORLD
    assert comm.size == 2
    sim = Simulation(load_scene(scene), comm=comm)
    sim.advance_steps(settle)
    sim.sync_ghost_velocities()
    e0, e1 = sim.decomp.sectors.edges[:2]  # rank 0 owns angles e0 <= phi < e1
    n_move = int(sim.clock.n_move[0])
    ang = np.mod(np.arctan2(sim.ps.x[:n_move, 1], sim.ps.x[:n_move, 0]) - e0, 2 * np.pi)
    best = (np.inf, -1)
    if comm.rank == 0:
        for k in np.argsort(np.abs(ang - (e1 - e0))):
            c = contacts_of(sim, sim.ps.gid[k])
            if (np.abs(c["spring"]).sum(axis=1) > 0).sum() >= 2:
                best = (float(ang[k]), int(sim.ps.gid[k]))
                break
    ang_p, gid = comm.bcast(best, root=0)
    assert gid >= 0, "no loaded particle near the edge"
    before = contacts_of(sim, gid)
    full = comm.bcast(before, root=0)  # the owner (rank 0) lists all of gid's contacts
    same_as_owner(before, full)  # the ghost side lists some of them, with the same bits
    # Move the edge so that the particle now lies on rank 1's side, then rebuild.
    edges = sim.decomp.sectors.edges.copy()
    edges[1] = e0 + ang_p - 1e-9
    sim.decomp.sectors = sim.decomp.sectors._replace(edges=edges)
    migrated0 = sim.decomp.n_migrated
    sim._rebuild()
    sim.sync_ghost_velocities()
    owned = set(sim.ps.gid[: int(sim.clock.n_move[0])].tolist())
    arrived = comm.allgather(gid in owned)
    assert arrived == [False, True], arrived
    assert comm.allreduce(sim.decomp.n_migrated - migrated0) >= 1
    after_tab = contacts_of(sim, gid)
    same_as_owner(after_tab, full)
    if comm.rank == 1:  # the new owner has every contact, springs intact
        assert after_tab["ids"].shape == full["ids"].shape
    loaded = int((np.abs(full["spring"]).sum(axis=1) > 0).sum())
    sim.advance_steps(after)
    arrays, attrs = sim.checkpoint_state() or (None, None)
    if comm.rank == 0:
        np.savez(out, **arrays, step=attrs["step"], moved_gid=gid, loaded_contacts=loaded)


if __name__ == "__main__":
    main()

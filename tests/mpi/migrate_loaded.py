"""Force a particle with loaded contacts across a sector edge (2 ranks) and check its springs.

    mpiexec -n 2 python -m mpi4py tests/mpi/migrate_loaded.py SCENE SETTLE_STEPS AFTER_STEPS OUT.npz

After SETTLE_STEPS, picks the owned particle of rank 0 nearest to a sector edge that has at least
two touching contacts with non-zero springs, records the forces and springs of each of its
contacts as *both* ranks applied them, moves the edge just past the particle and rebuilds (the
particle migrates to rank 1 with its springs), checks the springs again (the forces are not
recomputed by a build), takes one step and checks that both ranks applied the same forces,
then runs AFTER_STEPS more and saves the gathered state (compared with a serial run by the
test).
A failed check raises on the rank that finds it; ``python -m mpi4py`` then aborts every rank.
"""

import sys

import numpy as np
from mpi4py import MPI

from pardem.input.scene_file import load_scene
from pardem.simulation import Simulation


def contacts_of(sim, gid):
    """This rank's view of gid's touching contacts (every listed pair, owned or not), with the
    forces it applied."""
    t = sim.local_view()[2].pairs
    del t["index"]  # storage indices differ between ranks
    rows = np.flatnonzero((t["ids"] == gid).any(axis=1))
    return {k: v[rows] for k, v in t.items()}


HISTORY = ("ids", "spring", "displacement")


def same_as_owner(table, full, keys=None):
    """Every contact in this rank's table equals the owner's, bit for bit (``keys``: the columns
    compared, default all); at least one shown."""
    assert table["ids"].shape[0] >= 1
    rows = [int(np.flatnonzero((full["ids"] == pair).all(axis=1))[0]) for pair in table["ids"]]
    for k in keys or full:
        if k in full:
            assert np.array_equal(table[k], full[k][rows]), k


def main():
    scene, settle, after, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    comm = MPI.COMM_WORLD
    assert comm.size == 2
    sim = Simulation(load_scene(scene), comm=comm)
    sim.advance_steps(settle)
    e0, e1 = sim.decomp.cut.edges[0, :2]  # rank 0 owns angles e0 <= phi < e1
    n_owned = int(sim.clock.n_owned[0])
    ang = np.mod(np.arctan2(sim.ps.x[:n_owned, 1], sim.ps.x[:n_owned, 0]) - e0, 2 * np.pi)
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
    edges = sim.decomp.cut.edges.copy()
    edges[0, 1] = e0 + ang_p - 1e-9
    sim.decomp.cut = sim.decomp.cut._replace(edges=edges)
    migrated0 = sim.decomp.n_migrated
    sim.rebuilder.rebuild()
    owned = set(sim.ps.gid[: int(sim.clock.n_owned[0])].tolist())
    arrived = comm.allgather(gid in owned)
    assert arrived == [False, True], arrived
    assert comm.allreduce(sim.decomp.n_migrated - migrated0) >= 1
    after_tab = contacts_of(sim, gid)
    same_as_owner(after_tab, full, HISTORY)
    if comm.rank == 1:  # the new owner has every contact, springs intact
        assert after_tab["ids"].shape == full["ids"].shape
    loaded = int((np.abs(full["spring"]).sum(axis=1) > 0).sum())
    sim.advance_steps(1)  # both ranks apply the migrant's forces: the same bits
    stepped = contacts_of(sim, gid)
    same_as_owner(stepped, comm.bcast(stepped, root=1))
    sim.advance_steps(after - 1)
    arrays, attrs = sim.checkpoint_state() or (None, None)
    if comm.rank == 0:
        np.savez(out, **arrays, step=attrs["step"], moved_gid=gid, loaded_contacts=loaded)


if __name__ == "__main__":
    main()

"""Run a scene for a number of steps on the ranks of COMM_WORLD and save the gathered state.

    mpiexec -n P python -m mpi4py tests/mpi/dump_state.py SCENE STEPS OUT.npz [--restart CKPT]
        [--from CKPT] [--checkpoint-at STEP CKPT] [--grow-window] [--shared-limit DOUBLES] [--check-lists]
        [--no-room] [--cut auto|sectors|RxA] [--balance-threshold F] [--timing]

Rank 0 writes OUT.npz with every particle array and the springs (sorted by gid), plus the run's
migration and rebuild counts and, summed over the ranks, the wall disks a rank does not move
and the listed pairs that involve one of those (must be none); the tests compare these files
between rank counts. ``--grow-window``: start the shared-memory ghost refresh with a window
too small for it, so that the next build must replace it. ``--shared-limit``: the largest
refresh (doubles per rank) sent through shared memory, instead of
``pardem.parallel.comm.SHARED_HALO_LIMIT``. ``--check-lists``: after every neighbour build (local
or with an exchange), the ranks' pair lists together must be exactly the pairs a brute-force
search finds in the gathered positions (a ghost missing after a build without exchange would
lose a pair); the number of builds checked is saved. ``--no-room``: after every build the
particle arrays are cut to the rows in use, so that an exchange that brings more rows than it
takes away stores them in larger arrays (``Decomposition.exchange``) instead of in
place; the number of such exchanges on a rank that received migrants is saved. ``--cut``: the
decomposition (``Simulation(cut=...)``); the rings of the cut used are saved.
``--balance-threshold``: re-cut when the owned counts differ by more than this fraction
(default 0.1; 0 re-cuts at nearly every check). ``--timing``: the step loop with its stage
timers (``Simulation(timing=True)``); each rank's ``Clock.deep`` followed by its
``Decomposition.wait`` is saved as a row of ``timing``.
"""

import argparse

import numpy as np
from mpi4py import MPI

from pardem.parallel import comm as decomposition
from pardem.parallel.halo import SharedWindow
from pardem.core.rebuild import Rebuilder
from pardem.input.scene_file import load_scene
from pardem.simulation import Simulation
from pardem.core.state import new_particles, packed, unpack_particles
from pardem.testing import brute_force_pairs

CHECKED = [0]
REGROWN = [0]


def check_lists(sim, comm) -> None:
    """Every rank's listed pairs (gids), joined, equal brute force over the bodies the ranks
    move (owned particles and the wall disks near each sector: together, every body)."""
    ps, c, pr = sim.ps, sim.clock, sim.pairs
    moved = slice(0, int(c.n_moving[0]))
    k = int(pr.count[0])
    mine = (ps.gid[moved], ps.x[moved], ps.radius[moved], ps.kind[moved],
            {(int(a), int(b)) for a, b in zip(ps.gid[pr.i[:k]], ps.gid[pr.j[:k]])})
    parts = comm.gather(mine, root=0)
    if comm.rank == 0:
        gid = np.concatenate([p[0] for p in parts])
        gid, first = np.unique(gid, return_index=True)  # wall disks near two sectors: same bits
        x, radius, kind = (np.concatenate([p[q] for p in parts])[first] for q in (1, 2, 3))
        listed = set().union(*(p[4] for p in parts))
        expected = brute_force_pairs(x, radius, gid, kind, sim.prm.skin, sim.prm.wall_skin)
        assert listed == expected, (f"step {int(c.step[0])}: {len(expected - listed)} pairs "
                                    f"missing, {len(listed - expected)} extra")
    CHECKED[0] += 1


def checked_rebuild(comm):
    original = Rebuilder.rebuild

    def rebuild(self, *args, **kwargs):
        original(self, *args, **kwargs)
        check_lists(self.sim, comm)
    return rebuild


def cut_to_rows_in_use(comm):
    """Rebuilder.rebuild, then the particle arrays cut to their rows in use; counts in
    REGROWN the builds that had to store the rows in larger arrays while migrants arrived."""
    original = Rebuilder.rebuild

    def rebuild(self, *args, **kwargs):
        sim = self.sim
        ps, arrived = sim.ps, sim.decomp.n_migrated
        original(self, *args, **kwargs)
        REGROWN[0] += sim.ps is not ps and sim.decomp.n_migrated > arrived
        c = sim.clock
        n = int(c.n_local[0] + c.n_ghost[0])
        tight = new_particles(n, sim.hist)
        unpack_particles(packed(sim.ps, np.arange(n), sim.hist), tight, 0)
        sim.ps = tight
    return rebuild


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("steps", type=int)
    ap.add_argument("out")
    ap.add_argument("--restart")
    ap.add_argument("--from", dest="branch")
    ap.add_argument("--checkpoint-at", nargs=2)
    ap.add_argument("--grow-window", action="store_true")
    ap.add_argument("--shared-limit", type=int)
    ap.add_argument("--check-lists", action="store_true")
    ap.add_argument("--no-room", action="store_true")
    ap.add_argument("--cut", default="auto")
    ap.add_argument("--balance-threshold", type=float)
    ap.add_argument("--timing", action="store_true")
    args = ap.parse_args()
    if args.shared_limit is not None:
        decomposition.SHARED_HALO_LIMIT = args.shared_limit
    comm = MPI.COMM_WORLD
    if args.check_lists:
        Rebuilder.rebuild = checked_rebuild(comm)
    if args.no_room:
        Rebuilder.rebuild = cut_to_rows_in_use(comm)
    sim = Simulation(load_scene(args.scene), restart=args.restart, comm=comm, cut=args.cut,
                     branch=args.branch, timing=args.timing)
    if args.balance_threshold is not None:
        sim.decomp.balance_threshold = args.balance_threshold
    if args.grow_window and sim.decomp.window is not None:  # None: messages (oversubscribed)
        sim.decomp.window.free()
        sim.decomp.window = SharedWindow(comm, 4)
        sim.rebuilder.rebuild()  # a build at the same state changes no bit; it replaces the window
    if args.checkpoint_at:
        at = int(args.checkpoint_at[0])
        sim.advance_steps(at - int(sim.clock.step[0]))
        sim.write_checkpoint(args.checkpoint_at[1])
    sim.advance_steps(args.steps - int(sim.clock.step[0]))
    arrays, attrs = sim.checkpoint_state() or (None, None)
    migrated = comm.allreduce(sim.decomp.n_migrated)
    # wall disks this rank does not move, and listed pairs that would need one of them
    c, pr = sim.clock, sim.pairs
    idle = slice(int(c.n_moving[0]), int(c.n_local[0]))
    k = pr.count[0]
    in_idle = ((pr.i[:k] >= idle.start) & (pr.i[:k] < idle.stop)) | (
        (pr.j[:k] >= idle.start) & (pr.j[:k] < idle.stop))
    idle_walls = comm.allreduce(idle.stop - idle.start)
    idle_pairs = comm.allreduce(int(in_idle.sum()))
    regrown = comm.allreduce(REGROWN[0])
    timing = np.array(comm.gather(np.append(sim.clock.deep, sim.decomp.wait), root=0))
    if comm.rank == 0:
        np.savez(args.out, **arrays, step=attrs["step"], migrated=migrated,
                 rebuilds=sim.n_rebuilds, exchanges=sim.decomp.n_exchanges,
                 lists_checked=CHECKED[0], regrown=regrown,
                 rebalanced=sim.decomp.n_rebalanced,
                 idle_walls=idle_walls, idle_wall_pairs=idle_pairs,
                 shared_windows=sim.decomp.n_windows,
                 shared_exchanges=sim.decomp.n_shared_exchanges, rings=sim.decomp.cut.rings,
                 timing=timing)


if __name__ == "__main__":
    main()

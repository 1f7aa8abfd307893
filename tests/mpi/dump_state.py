"""Run a scene for a number of steps on the ranks of COMM_WORLD and save the gathered state.

    mpiexec -n P python -m mpi4py tests/mpi/dump_state.py SCENE STEPS OUT.npz [--restart CKPT]
        [--checkpoint-at STEP CKPT]

Rank 0 writes OUT.npz with every particle array and the springs (sorted by gid), plus the run's
migration and rebuild counts; the tests compare these files between rank counts.
"""

import argparse

import numpy as np
from mpi4py import MPI

from pardem.scene import load_scene
from pardem.simulation import Simulation


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("steps", type=int)
    ap.add_argument("out")
    ap.add_argument("--restart")
    ap.add_argument("--checkpoint-at", nargs=2)
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    sim = Simulation(load_scene(args.scene), restart=args.restart, comm=comm)
    if args.checkpoint_at:
        at = int(args.checkpoint_at[0])
        sim.advance_steps(at - int(sim.clock.step[0]))
        sim.write_checkpoint(args.checkpoint_at[1])
    sim.advance_steps(args.steps - int(sim.clock.step[0]))
    arrays, attrs = sim.checkpoint_state() or (None, None)
    migrated = comm.allreduce(sim.decomp.n_migrated)
    if comm.rank == 0:
        np.savez(args.out, **arrays, step=attrs["step"], migrated=migrated,
                 rebuilds=sim.n_rebuilds, rebalanced=sim.decomp.n_rebalanced)


if __name__ == "__main__":
    main()

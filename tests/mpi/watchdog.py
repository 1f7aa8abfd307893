"""``pardem run`` (the real CLI) where rank 1 poisons one of its particles with NaN right after
the checkpoint at t = 0.05 s: every rank must stop with the particle's id, time and position,
exit with status 3, and leave that checkpoint as it was."""

import sys

import numpy as np
from mpi4py import MPI

from pardem import cli
from pardem.simulation import Simulation

original = Simulation.write_checkpoint


def write_checkpoint(self, *args, **kwargs):
    original(self, *args, **kwargs)
    if MPI.COMM_WORLD.rank == 1 and self.clock.n_owned[0] > 0:
        self.ps.v[0, 0] = np.nan


Simulation.write_checkpoint = write_checkpoint
sys.exit(cli.main(["run", sys.argv[1], "--out", sys.argv[2], "--end", "0.2", "--quiet"]))

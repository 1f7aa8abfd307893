"""``pardem run`` (the real CLI) where rank 1 throws one of its disks at its nearest neighbour at
60 m/s right after the checkpoint at t = 0.05 s: the pair overlaps beyond MAX_OVERLAP within a
step or two, and every rank must stop naming the two particles, exit with status 3, and leave
that checkpoint as it was."""

import sys

import numpy as np
from mpi4py import MPI

from pardem import cli
from pardem.simulation import Simulation

original = Simulation.write_checkpoint


def write_checkpoint(self, *args, **kwargs):
    original(self, *args, **kwargs)
    n = int(self.clock.n_owned[0])
    if MPI.COMM_WORLD.rank == 1 and n > 1:
        x = self.ps.x[:n]
        d = np.hypot(*(x[1:] - x[0]).T)
        k = 1 + int(np.argmin(d))
        self.ps.v[0] = 60.0 * (x[k] - x[0]) / d[k - 1]


Simulation.write_checkpoint = write_checkpoint
sys.exit(cli.main(["run", sys.argv[1], "--out", sys.argv[2], "--end", "0.2", "--quiet"]))

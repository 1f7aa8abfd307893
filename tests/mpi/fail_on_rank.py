"""``pardem run`` (the real CLI, no mpi4py runner) where rank 1 raises in the middle of the run
(at a neighbour build after step 500, while rank 0 waits in the ghost exchange): the CLI must
print the error and abort the job instead of leaving rank 0 waiting forever."""

import sys

from mpi4py import MPI

from pardem import cli
from pardem.core.rebuild import Rebuilder

original = Rebuilder.rebuild


def _rebuild(self, *args, **kwargs):
    if MPI.COMM_WORLD.rank == 1 and self.sim.clock.step[0] > 500:
        raise RuntimeError("injected failure on rank 1")
    original(self, *args, **kwargs)


Rebuilder.rebuild = _rebuild
sys.exit(cli.main(["run", sys.argv[1], "--out", sys.argv[2], "--end", "1.0", "--quiet"]))

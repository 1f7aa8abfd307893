"""Disks centred exactly on the sector edges of a 2-rank decomposition, on any number of ranks.

    mpiexec -n P python -m mpi4py tests/mpi/edge_particles.py SCENE STEPS OUT.npz

The edges are the ones a 2-rank run cuts for this scene (from the initial positions, the same
on every rank count). Free particles 0 and 1 are moved onto the two edge rays at mid-radius,
at rest; the run continues STEPS steps and rank 0 saves the gathered state (as dump_state.py)
plus the number of ranks that owned particle 0 right after the move (must be exactly 1).
"""

import sys

import numpy as np
from mpi4py import MPI

from pardem.parallel import cut
from pardem.parallel.choice import HIST_BINS
from pardem.input.placement import initial_configuration
from pardem.input.scene_file import load_scene
from pardem.simulation import Simulation

scene = load_scene(sys.argv[1])
steps, out = int(sys.argv[2]), sys.argv[3]
comm = MPI.COMM_WORLD
init = initial_configuration(scene)
edges = cut.balanced(cut.angle_histogram(init.x[:init.n_free], HIST_BINS), 2).edges[0]
g = scene.geometry
r_mid = 0.5 * (g.inner_radius + g.outer_radius)
sim = Simulation(scene, comm=comm)
# collective: migrates the moved particles to their owners, new ghosts, forces
on_edges = [(r_mid * np.cos(a), r_mid * np.sin(a)) for a in (edges[1], edges[0])]
sim.set_particles([0, 1], position=on_edges, velocity=np.zeros((2, 2)))
owners = comm.allreduce(int(np.any(sim.ps.gid[: sim.clock.n_owned[0]] == 0)))
owned = comm.allreduce(int(sim.clock.n_owned[0]))
sim.advance_steps(steps)
arrays, attrs = sim.checkpoint_state() or (None, None)
if comm.rank == 0:
    np.savez(out, **arrays, step=attrs["step"], owners=owners, owned=owned,
             edge_x=r_mid * np.cos(edges[1]), edge_y=r_mid * np.sin(edges[1]))

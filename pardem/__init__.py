"""pardem: an MPI-parallel 2D discrete-element simulator of a granular Couette shear cell.

Data flow: scene.py (TOML -> frozen dataclasses) -> placement.py (initial arrays) ->
simulation.py (state, run loop, writers) -> stepper.py (compiled time-step loop: contact.py for
the force law, walls.py for the rings, neighbors.py for the Verlet list) -> output/.
Under MPI: sectors.py (who owns what: geometry only), decomposition.py (migration, ghosts,
gathers; mpi4py) and mpi_native.py (the per-step ghost refresh, called from compiled code).

Glossary (SI units throughout):
  gid       global particle id (free particles 0..N-1, then wall disks)
  k_n       normal spring stiffness (N/m);  gamma_n  normal viscous coefficient (kg/s)
  k_t       tangential spring stiffness (N/m);  mu  Coulomb friction coefficient
  xi        tangential spring (m), a 2D vector in the tangent plane of a contact
  delta     overlap (m) = a_i + a_j - |r_i - r_j|;  n  unit normal from j to i
  _ij       pair quantity in the (lower gid, higher gid) orientation
  t_c       contact time of the damped spring (s); e_n normal restitution coefficient
  skin      Verlet-list margin (m);  reach  largest overlap change in half a step (m)
  owned     a free particle whose centre lies in this rank's sector; ghost: a read-only copy
            of another rank's particle near the sector edge
"""

from .output.snapshots import read_snapshots
from .scene import Scene, SceneError, load_scene
from .simulation import Simulation, SimulationError

__all__ = ["Scene", "SceneError", "Simulation", "SimulationError", "load_scene",
           "read_snapshots"]

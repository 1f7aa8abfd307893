"""pardem: an MPI-parallel 2D discrete-element simulator of a granular Couette shear cell.

Data flow: input/ (scene.py: TOML -> frozen dataclasses, checked in schema.py;
placement.py: the initial arrays) -> simulation.py (state, run loop, writers; read it top to
bottom) -> core/step.py (the compiled time-step loop: integrate.py, forces.py with the contact
law of contact/, walls.py for the rings, neighbors.py and rebuild.py for the Verlet lists) ->
output/ (snapshots, checkpoints, restarts, the in-situ averages, progress). Under MPI:
parallel/ (sectors, migration, ghosts, gathers; the only place that imports mpi4py).
averaging/ turns contacts into ring fields; it sees pardem through sampling.py.

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

from importlib.metadata import PackageNotFoundError, version

from .output.snapshots import read_snapshots
from .input.scene import Scene, SceneError
from .input.scene_file import load_scene
from .simulation import Simulation, SimulationError

try:
    __version__ = version("pardem")
except PackageNotFoundError:  # a source tree on PYTHONPATH, not installed
    __version__ = "unknown"

__all__ = ["__version__", "Scene", "SceneError", "Simulation", "SimulationError", "load_scene",
           "read_snapshots"]

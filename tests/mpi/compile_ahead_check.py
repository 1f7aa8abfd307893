"""Run ``pardem.warmup.warm_up`` of a scene on the ranks of COMM_WORLD and the progress line's
diagnostics, then print (rank 0, one JSON line) per rank how many compiled versions it holds
of every kernel that ``compile_first`` and ``compile_ahead`` compile, and which of them it
compiled ahead. A kernel compiled ahead with the signature of the calls that follow has one
version on its rank; a kernel that other kernels call (and that
is loaded with them) may have none on another rank.

    mpiexec -n P python -m mpi4py tests/mpi/compile_ahead_check.py SCENE
"""

import json
import sys
import tempfile

from mpi4py import MPI

from pardem import compile_ahead
from pardem.input.scene_file import load_scene
from pardem.warmup import warm_up

comm = MPI.COMM_WORLD
seen, ahead = [], []


def recording(original):
    def groups_of(*args):
        groups = original(*args)
        seen.extend(kernel for group in groups for kernel, _ in group)
        ahead.extend(kernel for kernel, _ in groups[comm.rank] if comm.rank < len(groups))
        return groups
    return groups_of


compile_ahead._groups = recording(compile_ahead._groups)
compile_ahead._first_groups = recording(compile_ahead._first_groups)
with tempfile.TemporaryDirectory() as tmp:
    sim = warm_up(load_scene(sys.argv[1]), tmp, comm)
    sim.kinetic_energy(), sim.max_overlap()  # what the progress line calls (collective)
mine = {"versions": {k.py_func.__qualname__: len(k.overloads) for k in seen},
        "ahead": [k.py_func.__qualname__ for k in ahead]}
every = comm.gather(mine, root=0)
if comm.rank == 0:
    print(json.dumps(every))

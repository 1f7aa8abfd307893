"""``pardem warmup``: compile ahead what a run of a scene calls, on this many ranks.

Stage: entry point. Numba compiles a kernel at its first call and caches it on disk; a
scene's first run therefore spends a minute compiling. ``warm_up`` runs a few steps with every
writer firing, so that a batch job (or a benchmark of the cold compile,
``run_scripts/benchmarks/compile_times.py``) finds every kernel in the cache.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from .input.scene import Scene
from .simulation import Simulation


def warm_up(scene: Scene, out_dir: str | Path, comm=None) -> Simulation:
    """Build ``scene`` (decomposed over ``comm``'s ranks) and run four steps with every writer
    firing (snapshots, checkpoints, ring samples) into the scratch folder ``out_dir``, then a
    neighbour build as the step loop asks for one: numba then has compiled, and cached on disk,
    every kernel a run of this scene on this many ranks calls (``tests/test_mpi.py`` checks
    that a run after it saves nothing to the cache). ``pardem warmup`` and
    ``run_scripts/benchmarks/compile_times.py`` both do this."""
    sim = Simulation(scene, out_dir=out_dir, comm=comm)
    dt = sim.dt
    averaging = scene.averaging and dataclasses.replace(
        scene.averaging, start=0.0, end=4 * dt, sample_interval=2 * dt)
    sim.scene = dataclasses.replace(scene, averaging=averaging, output=dataclasses.replace(
        scene.output, snapshot_interval=2 * dt, checkpoint_interval=2 * dt))
    sim.run(end=4 * dt, progress=False)
    # four steps rarely need a neighbour build: one as the step loop asks for it (under MPI,
    # the test whether particles moved far enough to migrate compiles only here)
    sim.rebuilder.rebuild(forced=False)
    return sim

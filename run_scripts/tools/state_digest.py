"""Digest of a run's state: the bits a refactor or a new option must keep.

    [mpiexec -n P] python run_scripts/tools/state_digest.py SCENE.toml [--end T] [--expect HEX]
                                                            [--displacement eta|spring]

Runs SCENE to time T (s; default the scene's end) without output and prints one sha256 over
every gathered particle array (sorted by id), the tangential springs keyed by gid pair (the
spring columns only: eta, where tracked, is not part of the dynamics) and, if the scene
averages, the raw ring sums of every sample (``--displacement`` overrides the scene's
[averaging] displacement). ``--expect HEX`` exits 1 unless the digest matches. Bits depend
on the machine's compiled code, so compare digests made on one machine (before and after a
change), never across machines.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import sys

import numpy as np

from pardem.input.scene_file import load_scene
from pardem.simulation import Simulation


def digest(sim: Simulation) -> str | None:
    """sha256 hex of the gathered state and ring sums (rank 0; None on the others)."""
    state = sim.checkpoint_state()
    rings = sim.rings
    if state is None:
        return None
    arrays, _ = state
    h = hashlib.sha256()
    for key in sorted(arrays):
        if key in ("pair_xi", "xi_wall"):  # spring columns only: eta is not dynamical state
            h.update(np.ascontiguousarray(arrays[key][:, :2]).tobytes())
        else:
            h.update(np.ascontiguousarray(arrays[key]).tobytes())
    if rings is not None:
        for s in rings.samples:
            h.update(np.ascontiguousarray(s).tobytes())
    return h.hexdigest()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--end", type=float, default=None, help="s (default: the scene's end)")
    ap.add_argument("--expect", default=None, help="exit 1 unless the digest equals this")
    ap.add_argument("--displacement", choices=["eta", "spring"], default=None)
    args = ap.parse_args(argv)
    comm = None
    try:
        from mpi4py import MPI

        comm = MPI.COMM_WORLD if MPI.COMM_WORLD.Get_size() > 1 else None
    except ImportError:
        pass
    scene = load_scene(args.scene)
    if args.displacement and scene.averaging is not None:
        scene = dataclasses.replace(scene, averaging=dataclasses.replace(
            scene.averaging, displacement=args.displacement))
    sim = Simulation(scene, comm=comm)
    sim.run(end=args.end, progress=False)
    hexd = digest(sim)
    if hexd is None:
        return 0
    print(f"{args.scene} t = {sim.time:.6g} s: {hexd}")
    if args.expect is not None and hexd != args.expect:
        print(f"digest differs from the expected {args.expect}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

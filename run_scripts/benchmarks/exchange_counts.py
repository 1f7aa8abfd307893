"""Benchmark: how many neighbour builds exchange particles and ghosts, on P ranks; optionally
against an older commit. Counts, not seconds: the same on a busy machine as on a quiet one.

    python run_scripts/benchmarks/exchange_counts.py [SCENE] [--ranks 2] [--steps 20000] [--from T]
                                                     [--against REV]

Runs SCENE (default couette_quick.toml) from t = 0 for ``--steps`` steps, or, with ``--from
T``, first to T seconds (not counted) and then ``--steps`` more, under ``mpiexec -n P`` with
this tree's code (and REV's, in a temporary worktree), and prints per tree the neighbour
builds, the exchanges among them, the particles migrated and the sector rebalances in the
counted steps, and a digest of the final state (the two trees must agree bit for bit).
"""

from __future__ import annotations

import argparse
import hashlib
from pathlib import Path

from side_by_side import ROOT, checkout, emit, mpi_job



def worker(scene_path: str, steps: int, start: float) -> None:
    import numpy as np
    from mpi4py import MPI

    from pardem.input.scene_file import load_scene
    from pardem.simulation import Simulation

    comm = MPI.COMM_WORLD
    sim = Simulation(load_scene(scene_path), comm=comm)
    sim.advance_steps(int(round(start / sim.dt)))
    d = sim.decomp
    before = (sim.n_rebuilds, d.n_exchanges, d.n_migrated, d.n_rebalanced)
    sim.advance_steps(steps)
    state = sim.checkpoint_state()
    migrated = comm.allreduce(d.n_migrated - before[2])
    if comm.rank == 0:
        arrays = state[0]
        digest = hashlib.sha256()
        for key in sorted(arrays):
            digest.update(key.encode() + np.ascontiguousarray(arrays[key]).tobytes())
        emit({
            "builds": sim.n_rebuilds - before[0], "exchanges": d.n_exchanges - before[1],
            "migrated": migrated, "rebalanced": d.n_rebalanced - before[3],
            "digest": digest.hexdigest()[:16]})


def one_job(tree: Path, args) -> dict:
    return mpi_job(tree, args.ranks, [str(Path(__file__).resolve()), "--worker",
                                      str(Path(args.scene).resolve()), "--steps",
                                      str(args.steps), "--from", str(args.start)])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?",
                    default=str(ROOT / "run_scripts" / "scenes" / "couette_quick.toml"))
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--steps", type=int, default=20_000)
    ap.add_argument("--from", dest="start", type=float, default=0.0)
    ap.add_argument("--against")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker(args.scene, args.steps, args.start)
    with checkout(args.against) as old:
        trees = [("this tree", ROOT)] + ([(args.against, old)] if old else [])
        print(f"{Path(args.scene).name}, {args.ranks} ranks, {args.steps} steps from "
              f"t = {args.start:g} s")
        print("| code | builds | exchanges | share | migrated | rebalanced | state digest |")
        print("|---|---|---|---|---|---|---|")
        for label, tree in trees:
            r = one_job(tree, args)
            print(f"| {label} | {r['builds']} | {r['exchanges']} | "
                  f"{r['exchanges'] / max(r['builds'], 1):.2f} | {r['migrated']} | "
                  f"{r['rebalanced']} | {r['digest']} |", flush=True)


if __name__ == "__main__":
    main()

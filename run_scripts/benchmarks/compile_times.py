"""Benchmark: the cold compile of a scene's kernels, per kernel group, on 1 or more ranks; optionally
against an older commit, side by side.

    python run_scripts/benchmarks/compile_times.py [SCENE] [--ranks 1 2] [--repeats 1]
                                                   [--against REV]

Each measurement is a fresh ``mpiexec -n P`` job with an empty numba cache (its own temporary
NUMBA_CACHE_DIR) that does what ``pardem warmup`` does: builds the scene (P ranks: decomposed),
runs a few steps with every writer on, and so compiles every kernel a run of that scene calls.
A listener on numba's compile events charges each compilation, minus the compilations nested
in it, to the nearest function of pardem or averaging on the stack: a kernel's group is its
module, and numba's own library code (array setitem, string formatting) is charged to the
kernel that pulled it in. Prints every job's seconds of compiling per rank and, per group, the
median over repeats of the longest any rank spent on it, and the job's wall time from process
start to the kernels being ready on every rank (imports included). ``--detail``: per function
instead of per module. ``--against REV``: the same jobs with the code of git revision REV (a
temporary worktree), alternating with this tree's, so that both see the same machine load.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from side_by_side import checkout, emit, mpi_job

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
DETAIL = bool(os.environ.get("PARDEM_COMPILE_DETAIL"))  # --detail: per function, not module
T_PROCESS = time.perf_counter()


def worker(scene_path: str) -> None:
    """One cold compile under mpiexec (this tree's or REV's pardem on sys.path); rank 0 prints a
    JSON line with the seconds per group."""
    from numba.core import event

    stack: list[list] = []
    spent: dict[str, float] = {}

    def owner(frame_names: list[str]) -> str:
        for name in reversed(frame_names):
            if name.startswith(("pardem.", "averaging.")):
                return name
        return "numba (outside pardem)"

    class Charge(event.Listener):
        def on_start(self, ev):
            fn = ev.data["dispatcher"].py_func
            stack.append([f"{fn.__module__}:{fn.__qualname__}", time.perf_counter(), 0.0])

        def on_end(self, ev):
            name, t0, nested = stack.pop()
            took = time.perf_counter() - t0
            group = owner([s[0] for s in stack] + [name])
            if not DETAIL:
                group = group.split(":")[0]
            spent[group] = spent.get(group, 0.0) + took - nested
            if stack:
                stack[-1][2] += took

    event.register("numba:compile", Charge())

    from mpi4py import MPI

    from pardem.input.scene_file import load_scene

    try:
        from pardem.warmup import warm_up
    except ImportError:  # a tree from before warm_up (--against an old REV)
        warm_up = _old_warm_up

    comm = MPI.COMM_WORLD
    scene = load_scene(scene_path)
    tmp = comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None)
    t0 = time.perf_counter()
    warm_up(scene, tmp, comm if comm.size > 1 else None)
    comm.Barrier()
    row = {"ready_s": time.perf_counter() - T_PROCESS, "compile_s": sum(spent.values()),
           "setup_and_steps_s": time.perf_counter() - t0, "groups": spent}
    rows = comm.gather(row, root=0)
    if comm.rank == 0:
        emit({"ranks": rows})


def _old_warm_up(scene, out_dir, comm):
    """pardem.warmup.warm_up for trees that predate it (their pardem warmup ran serially)."""
    import dataclasses

    from pardem.simulation import Simulation

    sim = Simulation(scene, out_dir=out_dir, comm=comm)
    period = 2 * sim.dt
    sim.scene = dataclasses.replace(
        scene, averaging=scene.averaging and dataclasses.replace(
            scene.averaging, start=0.0, end=2 * period, sample_interval=period),
        output=dataclasses.replace(scene.output, snapshot_interval=period,
                                   checkpoint_interval=period))
    sim.run(end=2 * period, progress=False)


def one_job(tree: Path, scene: Path, ranks: int) -> dict:
    with tempfile.TemporaryDirectory() as cache:  # a cold compile: an empty numba cache
        return mpi_job(tree, ranks, [str(Path(__file__).resolve()), "--worker", str(scene)],
                       {"NUMBA_CACHE_DIR": cache})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?",
                    default=str(ROOT / "run_scripts" / "scenes" / "couette_quick.toml"))
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--against", help="a git revision to measure side by side")
    ap.add_argument("--detail", action="store_true", help="per function instead of per module")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker(args.scene)
    scene = Path(args.scene).resolve()
    if args.detail:
        os.environ["PARDEM_COMPILE_DETAIL"] = "1"
    with checkout(args.against) as old:
        trees = {"new": ROOT, **({"old": old} if old else {})}
        results: dict = {(c, p): [] for c in trees for p in args.ranks}
        for k in range(args.repeats):
            for p in args.ranks:
                for code, tree in trees.items():
                    got = one_job(tree, scene, p)
                    results[code, p].append(got["ranks"])
                    each = ", ".join(f"{r['compile_s']:.1f}" for r in got["ranks"])
                    print(f"round {k + 1}: {code} code, {p} rank(s): kernels ready "
                          f"{max(r['ready_s'] for r in got['ranks']):.1f} s after start; "
                          f"seconds compiling on each rank: {each}", flush=True)
    report(results, list(trees), args.ranks, args.against)


def report(results: dict, codes: list[str], ranks: list[int], against: str | None) -> None:
    """Per group, the median over rounds of the longest any rank spent on it (ranks may share
    the work: pardem/compile_ahead.py); then the longest total on one rank, and the wall time
    to the kernels being ready on every rank."""
    def med(values):
        return statistics.median(values) if values else 0.0

    def group(run, g):
        return max(r["groups"].get(g, 0.0) for r in run)

    for p in ranks:
        groups = sorted({g for c in codes for run in results[c, p] for r in run
                         for g in r["groups"]},
                        key=lambda g: -med([group(run, g) for run in results[codes[0], p]]))
        head = " | ".join(f"{c} code (s)" for c in codes)
        print(f"\n{p} rank(s), the longest over the ranks, median of "
              f"{len(results[codes[0], p])} round(s)" + (f" (old = {against})" if against else "")
              + f"\n| kernel group | {head} |\n|---|" + "---|" * len(codes))
        for g in groups:
            cells = " | ".join(f"{med([group(run, g) for run in results[c, p]]):.1f}"
                               for c in codes)
            print(f"| {g} | {cells} |")
        for key, label in (("compile_s", "compiling, the busiest rank"),
                           ("ready_s", "process start to kernels ready on every rank")):
            cells = " | ".join(f"{med([max(r[key] for r in run) for run in results[c, p]]):.1f}"
                               for c in codes)
            print(f"| **{label}** | {cells} |")


if __name__ == "__main__":
    main()

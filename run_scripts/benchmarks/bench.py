"""Benchmark: flow-particle-steps per second of a Couette scene after its compression, on 1
and 2 ranks, and start-up cost; optionally against an older commit, side by side.

    python run_scripts/benchmarks/bench.py [--scene run_scripts/scenes/couette_B.toml]
                                           [--at 2.5] [--steps 20000] [--repeats 5]
                                           [--ranks 1 2] [--startup] [--eta off|on|both]
                                           [--against REV] [--checkpoint FILE] [--timing]

Runs the scene once to ``--at`` seconds (default 2.5 s: B's compression ends at 2 s; not timed)
and checkpoints it. Then times
``--repeats`` rounds of ``--steps`` shear steps, each round one run per rank count (in turn),
each run a fresh ``mpiexec -n P`` job restarted from that checkpoint (NUMBA_NUM_THREADS=1, one
core per rank; the clock starts after warm-up steps that include two neighbour builds and
stops at the last step of the slowest rank). Prints every run, the median, rank 0's per-stage
breakdown and the 2-rank speed-up (ratio of the medians, and the median of the per-round
ratios). ``--startup`` also measures `pardem run` from process start to the first step, with
an empty numba cache (cold) and again with the cache filled (warm). ``--eta``: whether the step
loop also tracks the paper's total tangential displacement eta (what a run that averages with
it or writes contacts pays); "both" alternates the two within every round and prints the cost
of eta as the ratio of the medians. Default "off", the dynamics alone. ``--checkpoint FILE``:
keep the compressed state there and reuse it if it exists (a 300k-disk compression takes
minutes; the file must come from this scene and ``--at``). ``--against REV``: the
same runs with the code of git revision REV (checked out into a temporary worktree, its own
bench.py's worker on its own compressed checkpoint of this tree's couette_B.toml, or on
``--checkpoint`` if given) alternating with this code's, round by round; prints the ratio of
the medians and the per-round ratios. ``--timing``: this code's runs also time each stage of
the step loop (``pardem run --timing``) and print its table per rank.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SCENES = ROOT / "run_scripts" / "scenes"
SCENE = SCENES / "couette_B.toml"


def layout(tree: Path) -> tuple[Path, Path]:
    """``(folder of bench.py, folder of the scenes)`` in ``tree``: run_scripts/benchmarks/ and
    run_scripts/scenes/, or run_scripts/ for both in a revision before the folders."""
    scripts = tree / "run_scripts"
    if (scripts / "benchmarks" / "bench.py").exists():
        return scripts / "benchmarks", scripts / "scenes"
    return scripts, scripts


def scene_of(path: Path, eta: bool):
    """The scene, its in-situ averages using eta (tracked) or the spring (not tracked); the
    benchmark writes no output, so nothing else asks for eta. A scene without [averaging]
    tracks no eta either way."""
    import dataclasses

    from pardem.input.scene_file import load_scene

    scene = load_scene(path)
    if scene.averaging is None:
        return scene
    return dataclasses.replace(scene, averaging=dataclasses.replace(
        scene.averaging, displacement="eta" if eta else "spring"))


def compress(ckpt: Path, scene: Path = SCENE, at: float = 2.5) -> None:
    from pardem.simulation import Simulation

    t0 = time.perf_counter()
    sim = Simulation(scene_of(scene, False))
    setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    sim.run(end=at, progress=False)
    print(f"{scene.name}: set-up {setup:.1f} s; to t = {at} s: {time.perf_counter() - t0:.1f} s "
          f"wall, {sim.step} steps, {sim.n_rebuilds} builds, largest overlap "
          f"{100 * sim.max_overlap():.2f} % d")
    sim.write_checkpoint(ckpt)


def compress_in(tree: Path, ckpt: Path, env: dict, scene: Path = SCENE, at: float = 2.5) -> None:
    """``compress`` with the code of ``tree`` (its own bench.py), in a process of its own. B to
    2.5 s passes no scene: an older bench.py's compress may not take one."""
    extra = "" if (scene, at) == (SCENE, 2.5) else f", Path({str(scene)!r}), {at!r}"
    subprocess.run([sys.executable, "-c", "import sys; from pathlib import Path; "
                    f"sys.path[:0] = [{str(tree)!r}, {str(layout(tree)[0])!r}]; "
                    f"import bench; bench.compress(Path({str(ckpt)!r}){extra})"],
                   check=True, env=dict(env, PYTHONPATH=str(tree)))


def past_two_builds(run) -> None:
    """Advance ``run`` (a Simulation) past two more neighbour builds: compiled code loaded and
    caches warm, the builds' code included. Timed runs start from there."""
    builds = run.n_rebuilds
    while run.n_rebuilds < builds + 2:
        run.advance_steps(50)


def worker(ckpt: str, steps: int, eta: bool, scene: Path = SCENE, timing: bool = False) -> None:
    """One timed run (under mpiexec): prints a JSON line on rank 0. ``timing``: the step loop
    with its per-stage timers (``pardem run --timing``), their table in the line."""
    from mpi4py import MPI

    from pardem.output.progress import stage_table
    from pardem.simulation import Simulation

    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    extra = {"timing": True} if timing else {}  # an older revision's worker knows no timing
    run = Simulation(scene_of(scene, eta), restart=ckpt, comm=comm if comm.size > 1 else None,
                     **extra)
    setup = time.perf_counter() - t0
    assert run.contact.eta == eta
    past_two_builds(run)
    run.reset_timers()
    exchanges = run.decomp.n_exchanges
    comm.Barrier()
    t0 = time.perf_counter()
    run.advance_steps(steps)
    comm.Barrier()
    wall = time.perf_counter() - t0
    mine = run.stats()
    mine["rss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # bytes (Linux)
    mine["setup"] = setup
    mine["exchange_s"] = run.rebuilder.exchange_seconds  # the exchanges' share of the builds
    mine.update({"step_us": 1e6 * run.timers["forces+integration"] / steps,
                 "rebuild_us": 1e6 * run.timers["neighbour rebuild"] / steps,
                 "wait_us": 1e6 * mine.pop("wait") / steps})
    ranks = comm.gather(mine, root=0)
    stages = stage_table(run) if timing else None  # collective
    if comm.rank == 0:
        print(json.dumps({"wall": wall, "n_free": run.n_free, "rebuilds": run.n_rebuilds,
                          "exchanges": run.decomp.n_exchanges - exchanges,
                          "ghosts": [r["ghosts"] for r in ranks], "ranks": ranks,
                          "breakdown": run.breakdown() + (f"\n{stages}" if stages else "")}))


def throughput(steps: int, repeats: int, ranks: list[int], eta: str = "off",
               against: str | None = None, scene: Path = SCENE,
               at: float = 2.5, checkpoint: Path | None = None,
               timing: bool = False) -> dict[int, float]:
    """Median flow-particle-steps/s for each rank count (also printed, with every run).

    The rank counts take turns (round k runs every count once), so that the machine's slow
    drifts (a shared VM: +-15 % over minutes) hit every count alike; the speed-up is also given
    as the median of the per-round ratios, each from runs a few seconds apart. ``eta`` "both":
    each rank count runs without and with eta in turn; the cost of eta is printed likewise.
    ``against``: a git revision whose code runs each round too (see the module docstring; its
    bench.py must know --scene unless ``scene`` is couette_B). ``timing``: this code's runs
    time their stages (``pardem run --timing``; the timers' cost is in its rates)."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    mpiexec = Path(sys.executable).parent / "mpiexec"
    variants = {"off": [False], "on": [True], "both": [False, True]}[eta]
    codes = ["new"] + (["old"] if against else [])
    rates: dict = {(c, p, e): [] for c in codes for p in ranks for e in variants}
    last: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        trees = {"new": ROOT}
        if against:
            trees["old"] = Path(tmp) / "old"
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach",
                            str(trees["old"]), against], check=True, capture_output=True)
            # both codes run this tree's scene (REV's may have had another wall layout)
            shutil.copyfile(SCENE, layout(trees["old"])[1] / "couette_B.toml")
        try:
            ckpts = {}
            for code, tree in trees.items():
                ckpts[code] = Path(tmp) / f"compressed-{code}.h5"
                if checkpoint is not None:  # both codes start from it (the new one makes it)
                    ckpts[code] = checkpoint
                    if checkpoint.exists():
                        print(f"{code} code: compressed state from {checkpoint}")
                        continue
                print(f"{code} code ({tree}):", end=" ", flush=True)
                compress_in(tree, ckpts[code], env, scene, at)
            for k in range(repeats):
                for p in ranks:
                    for e in variants:
                        for code in codes:
                            res = last[code, p, e] = _worker_run(
                                mpiexec, trees[code], ckpts[code], steps, e, p, env, scene,
                                timing and code == "new")
                            rates[code, p, e].append(res["n_free"] * steps / res["wall"])
                            print(f"{code if against else ''} {p} rank(s){', eta' if e else ''}, "
                                  f"run {k + 1}: {steps} steps in {res['wall']:.3f} s -> "
                                  f"{rates[code, p, e][-1] / 1e6:.2f} M flow-particle-steps/s "
                                  f"({steps / res['wall']:.0f} steps/s, {res['rebuilds']} "
                                  f"neighbour builds, ghosts per rank {res['ghosts']}"
                                  f"{_exchange_cost(res)})", flush=True)
        finally:
            if against:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                                str(trees["old"])], capture_output=True)
    if against:
        for p in ranks:
            for e in variants:
                new, old = rates["new", p, e], rates["old", p, e]
                per_round = [a / b for a, b in zip(new, old)]
                print(f"new / old on {p} rank(s){', eta' if e else ''}: "
                      f"{statistics.median(new) / statistics.median(old):.3f} (ratio of the "
                      f"medians, {statistics.median(new) / 1e6:.2f} M against "
                      f"{statistics.median(old) / 1e6:.2f} M); per round "
                      f"{', '.join(f'{x:.3f}' for x in per_round)}, spread "
                      f"{min(per_round):.3f}-{max(per_round):.3f}", flush=True)
    rates = {key[1:]: v for key, v in rates.items() if key[0] == "new"}
    last = {key[1:]: v for key, v in last.items() if key[0] == "new"}
    if eta == "both":
        for p in ranks:
            off, on = rates[p, False], rates[p, True]
            per_round = [a / b for a, b in zip(off, on)]
            m_off, m_on = statistics.median(off), statistics.median(on)
            print(f"cost of eta on {p} rank(s): time per step x {m_off / m_on:.3f} (ratio of the "
                  f"medians, {m_off / 1e6:.2f} M without, {m_on / 1e6:.2f} M with); per round: "
                  f"{', '.join(f'{x:.3f}' for x in per_round)}, spread "
                  f"{min(per_round):.3f}-{max(per_round):.3f}", flush=True)
    rates = {p: rates[p, variants[0]] for p in ranks}
    last = {p: last[p, variants[0]] for p in ranks}
    medians = {}
    for p in ranks:
        res = last[p]
        print(res["breakdown"])
        print("  rank  owned  ghosts  pairs  nbrs  sent/step  bytes sent/step  msgs/step  "
              "step us  (waiting)  rebuild us/step")
        for r, d in enumerate(res["ranks"]):
            nbytes = 8 * (3 * d["neighbours"] + 5 * d["sent"])
            msgs = 2 * d["neighbours"] + (1 if d["allreduce"] else 0)
            print(f"  {r:4d} {d['owned']:6d} {d['ghosts']:7d} {d['pairs']:6d} "
                  f"{d['neighbours']:5d} {d['sent']:10d} {nbytes:16d} {msgs:10d} "
                  f"{d['step_us']:8.1f} {d['wait_us']:10.1f} {d['rebuild_us']:16.1f}")
        medians[p] = statistics.median(rates[p])
        print(f"{scene.stem}, {res['n_free']} flow particles, {p} rank(s): median "
              f"{medians[p] / 1e6:.2f} M flow-particle-steps/s over {repeats} runs", flush=True)
    if 1 in medians:
        for p in medians:
            if p > 1:
                per_round = [a / b for a, b in zip(rates[p], rates[1])]
                print(f"speed-up on {p} ranks: {medians[p] / medians[1]:.2f} (ratio of the "
                      f"medians); per round: {', '.join(f'{x:.2f}' for x in per_round)}, "
                      f"median {statistics.median(per_round):.2f}")
    return medians


def _exchange_cost(res: dict) -> str:
    """', N exchanges, X ms each' (rank 0's mean, the lists' build after it not included)
    for a parallel run."""
    n = res.get("exchanges", 0)
    if not n:
        return ""
    return f", {n} exchanges, {1e3 * res['ranks'][0]['exchange_s'] / n:.1f} ms each on rank 0"


def _worker_run(mpiexec: Path, tree: Path, ckpt: Path, steps: int, eta: bool, ranks: int,
                env: dict, scene: Path = SCENE, timing: bool = False) -> dict:
    """One timed run of the code in ``tree`` (its own bench.py worker)."""
    out = subprocess.run(
        [str(mpiexec), "-n", str(ranks), sys.executable, "-m", "mpi4py",
         str(layout(tree)[0] / "bench.py"), "--worker", str(ckpt), "--steps", str(steps),
         "--eta", "on" if eta else "off", *(["--scene", str(scene)] if scene != SCENE else []),
         *(["--timing"] if timing else [])],
        check=True, capture_output=True, text=True, env=dict(env, PYTHONPATH=str(tree)),
        timeout=3600)
    return json.loads(out.stdout.strip().splitlines()[-1])


def startup() -> None:
    exe = Path(sys.executable).parent / "pardem"
    scene = SCENES / "couette_quick.toml"
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "numba-cache"))
        for label in ("cold (empty numba cache)", "warm (second process)"):
            t0 = time.perf_counter()
            subprocess.run([str(exe), "run", str(scene), "--out", str(Path(tmp) / "out"),
                            "--end", "0", "--quiet", "--overwrite"], check=True, env=env,
                           stderr=subprocess.DEVNULL)
            print(f"start-up {label}: {time.perf_counter() - t0:.2f} s "
                  "(process start to end of a 0-step run)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, default=SCENE, help="a Couette scene (default B)")
    ap.add_argument("--at", type=float, default=2.5, help="s: timed runs start here")
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--startup", action="store_true")
    ap.add_argument("--eta", choices=["off", "on", "both"], default="off")
    ap.add_argument("--against", metavar="REV", help="also run git revision REV's code, "
                    "alternating with this one (e.g. a commit before a change)")
    ap.add_argument("--checkpoint", type=Path, metavar="FILE",
                    help="keep the compressed state in FILE and reuse it when it exists")
    ap.add_argument("--timing", action="store_true", help="this code's runs time each stage "
                    "of the step loop (pardem run --timing) and print the table per rank")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args.worker, args.steps, args.eta == "on", args.scene.resolve(), args.timing)
        return
    if args.startup:
        startup()
    throughput(args.steps, args.repeats, args.ranks, args.eta, args.against,
               args.scene.resolve(), args.at,
               args.checkpoint.resolve() if args.checkpoint else None, args.timing)


if __name__ == "__main__":
    main()

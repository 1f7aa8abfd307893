"""Benchmark: steady throughput of Couette cells of several sizes on 1 and 2 ranks, all in one
invocation (the throughput table of docs/scaling.md, from results/scaling/throughput.csv).

    python run_scripts/benchmarks/scale_table.py
        [--scenes couette_B.toml couette_B_30k.toml ...] [--at 2.5 1.2 ...] [--checkpoints DIR]
        [--ranks 1 2] [--repeats 3] [--particle-steps 1e8] [--eta]

Each scene runs once to its ``--at`` time (past its compression; not timed) and is checkpointed
in ``--checkpoints`` (reused when there: a 300k compression takes many minutes). Then every
round runs every scene on every rank count in turn, each a fresh ``mpiexec`` job from the
checkpoint timing about ``--particle-steps`` flow-particle-steps after two warm-up builds
(``bench.py``'s worker: one core per rank). Prints every run, then per scene and rank count:
the median M flow-particle-steps/s with the spread over the rounds, that median over the
smallest scene's 1-rank median (per-particle cost, same invocation), the speed-up over 1 rank
(median of the per-round ratios and their range), the largest resident memory per rank (MB, and
bytes per owned disk), the restart's set-up (s, compiled code loaded from the cache), ghosts
per rank, and neighbour builds per 1000 steps; each run's line gives rank 0's time per build,
exchanges (migration, ghost selection and the lists: the builds that call
``Decomposition.exchange``) apart.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tomllib
from pathlib import Path

import bench

ROOT = Path(__file__).resolve().parents[2]
SCENE_DIR = ROOT / "run_scripts" / "scenes"
SCENES = ["couette_B.toml", "couette_B_30k.toml", "couette_B_300k.toml"]
AT = [2.5, 1.2, 2.5]  # s: past the compression (2 s for B, 0.69 s at 30k, 1.95 s at 300k)


def free_disks(scene: Path) -> int:
    return sum(s["count"] for s in tomllib.loads(scene.read_text())["species"])


def ensure_checkpoint(scene: Path, at: float, ckpt: Path, env: dict) -> None:
    if ckpt.exists():
        print(f"{scene.name}: compressed state from {ckpt}", flush=True)
        return
    ckpt.parent.mkdir(parents=True, exist_ok=True)
    tmp = ckpt.with_suffix(".tmp.h5")
    bench.compress_in(ROOT, tmp, env, scene, at)
    tmp.rename(ckpt)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=SCENES)
    ap.add_argument("--at", nargs="+", type=float, default=None, help="s, one per scene")
    ap.add_argument("--checkpoints", type=Path, default=ROOT / "runs" / "scale_table")
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--particle-steps", type=float, default=1e8)
    ap.add_argument("--eta", action="store_true",
                    help="track the tangential displacement eta in every run (a checkpoint "
                         "whose ring samples used it restarts only so)")
    args = ap.parse_args()
    scenes = [Path(s) if Path(s).exists() else SCENE_DIR / s for s in args.scenes]
    at = args.at or [AT[SCENES.index(s)] if s in SCENES else 2.5 for s in args.scenes]
    if len(at) != len(scenes):
        raise SystemExit(f"scale_table.py: --at needs one time per scene ({len(scenes)})")
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    mpiexec = Path(sys.executable).parent / "mpiexec"
    ckpts = {}
    for scene, t in zip(scenes, at):
        ckpts[scene] = args.checkpoints / f"{scene.stem}-{t:g}.h5"
        ensure_checkpoint(scene, t, ckpts[scene], env)
    rates: dict = {(s, p): [] for s in scenes for p in args.ranks}
    last: dict = {}
    for k in range(args.repeats):
        for scene in scenes:
            for p in args.ranks:
                steps = max(200, int(args.particle_steps / free_disks(scene)))
                res = bench._worker_run(mpiexec, ROOT, ckpts[scene], steps, args.eta, p, env,
                                        scene.resolve())
                res["steps"] = steps
                last[scene, p] = res
                rates[scene, p].append(res["n_free"] * steps / res["wall"])
                r0, n_x = res["ranks"][0], res["exchanges"]
                build_ms = 1e-3 * r0["rebuild_us"] * steps  # all builds, rank 0
                local = (build_ms - 1e3 * r0["exchange_s"]) / max(res["rebuilds"] - n_x, 1)
                print(f"round {k + 1}: {scene.stem}, {p} rank(s): {steps} steps in "
                      f"{res['wall']:.2f} s -> {rates[scene, p][-1] / 1e6:.2f} M "
                      f"flow-particle-steps/s, {res['rebuilds']} builds, {n_x} of them "
                      f"exchanges (rank 0: {local:.1f} ms per other build"
                      + (f", {1e3 * r0['exchange_s'] / n_x:.1f} ms per exchange" if n_x else "")
                      + f"), ghosts {res['ghosts']}",
                      flush=True)
    base = statistics.median(rates[scenes[0], min(args.ranks)])
    print("\n| N | ranks | M particle-steps/s (median; range) | per-particle speed vs "
          f"{scenes[0].stem} on {min(args.ranks)} rank | speed-up (median per round; range) | "
          "largest RSS per rank, MB (bytes per owned disk) | restart set-up, s | ghosts / rank "
          "| builds / 1000 steps |")
    print("|---|---|---|---|---|---|---|---|---|")
    for scene in scenes:
        for p in args.ranks:
            r, res = rates[scene, p], last[scene, p]
            line = f"| {res['n_free']:,} | {p} | {statistics.median(r) / 1e6:.2f}; " \
                   f"{min(r) / 1e6:.2f}-{max(r) / 1e6:.2f} | {statistics.median(r) / base:.2f} | "
            if p != min(args.ranks):
                ratios = [a / b for a, b in zip(r, rates[scene, min(args.ranks)])]
                line += f"{statistics.median(ratios):.2f}; {min(ratios):.2f}-{max(ratios):.2f} | "
            else:
                line += "| "
            rss = max(d["rss"] for d in res["ranks"])
            owned = max(d["owned"] for d in res["ranks"])
            line += (f"{rss / 2**20:.0f} ({rss / owned:.0f}) | "
                     f"{max(d['setup'] for d in res['ranks']):.1f} | "
                     f"{max(res['ghosts'])} | {1000 * res['rebuilds'] / res['steps']:.1f} |")
            print(line, flush=True)


if __name__ == "__main__":
    main()

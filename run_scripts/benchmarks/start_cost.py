"""Benchmark: what a Couette scene's start costs, for two or more versions of a scene side by
side (e.g. a dilute and a tight start): set-up time, then the compression and ``--settle``
seconds after it, on one core.

    python run_scripts/benchmarks/start_cost.py SCENE.toml [SCENE.toml ...] [--settle 0.5]
                                                [--repeats 1]

Per scene and round: set-up seconds (placement, arrays, first build, compiled code loaded),
simulated seconds to the end of the compression + settle, the steps and neighbour builds that
took, wall seconds, and at the end the kinetic energy per free disk (J) and the largest overlap
(% of the smaller diameter). The scenes take turns round by round, so the wall-time ratio of
two scenes comes from one invocation; steps, builds and the end state are counts and physics,
the same on a busy machine.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")


def one(path: Path, settle: float) -> dict:
    from pardem.core.diagnostics import kinetic_energy
    from pardem.input.scene_file import load_scene
    from pardem.simulation import Simulation

    scene = load_scene(path)
    t0 = time.perf_counter()
    sim = Simulation(scene)
    setup = time.perf_counter() - t0
    end = scene.geometry.compression_time + settle
    t0 = time.perf_counter()
    sim.run(end=end, progress=False)
    wall = time.perf_counter() - t0
    return {"setup": setup, "end": end, "steps": sim.step, "builds": sim.n_rebuilds,
            "wall": wall, "ke": kinetic_energy(sim.ps, sim.n_free) / sim.n_free,
            "overlap": 100 * sim.max_overlap()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+", type=Path)
    ap.add_argument("--settle", type=float, default=0.5, help="s after the compression")
    ap.add_argument("--repeats", type=int, default=1)
    args = ap.parse_args()
    walls: dict[Path, list[float]] = {p: [] for p in args.scenes}
    for k in range(args.repeats):
        for p in args.scenes:
            r = one(p, args.settle)
            walls[p].append(r["wall"])
            print(f"{p.name} round {k + 1}: set-up {r['setup']:.1f} s; to t = {r['end']:.3g} s: "
                  f"{r['steps']} steps, {r['builds']} builds ({r['steps'] / r['builds']:.1f} "
                  f"steps per build), {r['wall']:.1f} s wall; then kinetic energy "
                  f"{r['ke']:.3g} J per disk, largest overlap {r['overlap']:.2f} %", flush=True)
    first = args.scenes[0]
    for p in args.scenes[1:]:
        ratios = [a / b for a, b in zip(walls[p], walls[first])]
        ratio = statistics.median(walls[p]) / statistics.median(walls[first])
        print(f"wall time {p.name} / {first.name}: {ratio:.3f} (ratio of the medians; per "
              f"round {', '.join(f'{x:.3f}' for x in ratios)})")


if __name__ == "__main__":
    main()

"""Benchmark: flow-particle-steps per second on couette_B after compression, and start-up cost.

    python run_scripts/bench.py [--steps 20000] [--repeats 5] [--startup]

Compresses scene B once (t = 0 .. 2.5 s, not timed), checkpoints it, then times ``--repeats``
runs of ``--steps`` shear steps, each restarted from that checkpoint, on one core
(NUMBA_NUM_THREADS=1). Prints every run, the median, and the per-stage breakdown.
``--startup`` also measures `pardem run` from process start to the first step, with an empty
numba cache (cold) and again with the cache filled (warm).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
HERE = Path(__file__).resolve().parent


def throughput(steps: int, repeats: int) -> None:
    from pardem.scene import load_scene
    from pardem.simulation import Simulation

    scene = load_scene(HERE / "couette_B.toml")
    with tempfile.TemporaryDirectory() as tmp:
        ckpt = Path(tmp) / "compressed.h5"
        sim = Simulation(scene)
        t0 = time.perf_counter()
        sim.run(end=2.5, progress=False)
        print(f"compression to t = 2.5 s: {time.perf_counter() - t0:.1f} s wall, "
              f"{sim.clock.step[0]} steps, largest overlap {100 * sim.max_overlap():.2f} % d")
        sim.write_checkpoint(ckpt)
        rates = []
        for k in range(repeats):
            run = Simulation(scene, restart=ckpt)
            run.advance_steps(10)  # compiled code loaded, caches warm
            for key in run.timers:
                run.timers[key] = 0.0
            run.n_rebuilds = 0
            t0 = time.perf_counter()
            run.advance_steps(steps)
            wall = time.perf_counter() - t0
            rates.append(run.n_free * steps / wall)
            print(f"run {k + 1}: {steps} steps in {wall:.3f} s -> {rates[-1] / 1e6:.2f} M "
                  f"flow-particle-steps/s ({steps / wall:.0f} steps/s, "
                  f"{run.n_rebuilds} neighbour builds)")
        print(run.breakdown())
        print(f"couette_B, {run.n_free} flow particles, 1 core: median "
              f"{statistics.median(rates) / 1e6:.2f} M flow-particle-steps/s over {repeats} runs")


def startup() -> None:
    exe = Path(sys.executable).parent / "pardem"
    scene = HERE / "couette_quick.toml"
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "numba-cache"))
        for label in ("cold (empty numba cache)", "warm (second process)"):
            t0 = time.perf_counter()
            subprocess.run([str(exe), "run", str(scene), "--out", str(Path(tmp) / "out"),
                            "--end", "0", "--quiet"], check=True, env=env,
                           stderr=subprocess.DEVNULL)
            print(f"start-up {label}: {time.perf_counter() - t0:.2f} s "
                  "(process start to end of a 0-step run)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--startup", action="store_true")
    args = ap.parse_args()
    if args.startup:
        startup()
    throughput(args.steps, args.repeats)


if __name__ == "__main__":
    main()

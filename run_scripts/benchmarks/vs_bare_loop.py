"""Benchmark: pardem against a bare numba loop of the same contact law, on one core.

    python run_scripts/benchmarks/vs_bare_loop.py [--repeats 5] [--steps 10000] [--at 2.5]
                                                  [--scene FILE] [--checkpoint FILE]

The bare loop is the yardstick of what a plain numba time step of this law costs on this
machine: the physics of a step written as one would first write it (a loop per stage, the
law inline in the pair loop, pardem's compile options), with none of a simulator's duties.
It starts from the same state as pardem's timed run (the checkpoint at ``--at`` seconds, two
neighbour builds later) and keeps pardem's pair list of that moment fixed (its pairs within
the skin, with their tangential springs). One step:

    half kick and drift of every disk (x += dt v; wall disks keep their velocity)
    every listed pair: distance test, then the linear spring, the viscous normal damping, the
        tangential spring (rotated by projection, plus v_t dt) with Coulomb's cap, and the
        forces and torques added to both disks
    closing half kick and bottom friction of the free disks

What it leaves out, and pardem does: the flat ring contacts and the rings' motion; neighbour
builds and the skin test that triggers them; predicted velocities (it uses the half-step
velocity, as LAMMPS does) and the damping window; the bad-particle and overlap watchdogs;
recording forces for output. Its packing therefore drifts from pardem's over a run (no list
update, no flat ring), so it runs in chunks of CHUNK steps, each from the start state again;
the fraction of listed pairs touching is printed at a chunk's first and last step.

Each round runs the bare loop and then pardem's bench worker (``bench.py``), each a fresh
process on one core (NUMBA_NUM_THREADS=1); prints each run's flow-particle-steps/s, the
medians, and pardem over the bare loop per round with the median and the spread.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba as nb
import numpy as np

from bench import ROOT, SCENE, _worker_run, compress, past_two_builds, scene_of

JIT = dict(cache=True, error_model="numpy")
CHUNK = 1000  # steps the bare loop runs from the start state before it starts again


@nb.njit(**JIT)
def bare_steps(x, v, w, f, tau, radius, inv_m, inv_i, free, pi, pj, hist, law, steps):
    """``steps`` velocity-Verlet steps of the disks on the fixed pair list (pi, pj, hist);
    ``law`` = (dt, k_n, gamma_n, k_t, mu, mu_b g). Returns the pairs touching at the end."""
    dt, k_n, gamma_n, k_t, mu, mu_b_g = law
    h = 0.5 * dt
    dv_b = mu_b_g * dt
    n = x.shape[0]
    touching = 0
    for _ in range(steps):
        for k in range(n):
            v[k, 0] += h * f[k, 0] * inv_m[k]
            v[k, 1] += h * f[k, 1] * inv_m[k]
            w[k] += h * tau[k] * inv_i[k]
            x[k, 0] += dt * v[k, 0]
            x[k, 1] += dt * v[k, 1]
        for k in range(n):
            f[k, 0] = 0.0
            f[k, 1] = 0.0
            tau[k] = 0.0
        touching = 0
        for p in range(pi.size):
            i, j = pi[p], pj[p]
            dx = x[i, 0] - x[j, 0]
            dy = x[i, 1] - x[j, 1]
            rs = radius[i] + radius[j]
            r2 = dx * dx + dy * dy
            if r2 >= rs * rs:
                hist[p, 0] = 0.0
                hist[p, 1] = 0.0
                continue
            touching += 1
            dist = math.sqrt(r2)
            nx, ny = dx / dist, dy / dist
            delta = rs - dist
            s = radius[i] * w[i] + radius[j] * w[j]
            vx = v[i, 0] - v[j, 0] + s * ny
            vy = v[i, 1] - v[j, 1] - s * nx
            vn = vx * nx + vy * ny
            fn = k_n * delta - gamma_n * vn
            xn = hist[p, 0] * nx + hist[p, 1] * ny
            xix = hist[p, 0] - xn * nx + (vx - vn * nx) * dt
            xiy = hist[p, 1] - xn * ny + (vy - vn * ny) * dt
            ftx, fty = -k_t * xix, -k_t * xiy
            fmax = mu * abs(fn)
            ft2 = ftx * ftx + fty * fty
            if ft2 > fmax * fmax:
                cap = fmax / math.sqrt(ft2)
                ftx *= cap
                fty *= cap
                xix, xiy = -ftx / k_t, -fty / k_t
            hist[p, 0] = xix
            hist[p, 1] = xiy
            fx, fy = fn * nx + ftx, fn * ny + fty
            nxft = nx * fty - ny * ftx
            f[i, 0] += fx
            f[i, 1] += fy
            f[j, 0] -= fx
            f[j, 1] -= fy
            tau[i] -= (radius[i] - 0.5 * delta) * nxft
            tau[j] -= (radius[j] - 0.5 * delta) * nxft
        for k in free:
            vx = v[k, 0] + h * f[k, 0] * inv_m[k]
            vy = v[k, 1] + h * f[k, 1] * inv_m[k]
            speed = math.sqrt(vx * vx + vy * vy)
            c = 0.0 if speed <= dv_b else 1.0 - dv_b / speed
            v[k, 0] = vx * c
            v[k, 1] = vy * c
            w[k] += h * tau[k] * inv_i[k]
    return touching


def bare_worker(ckpt: str, steps: int, scene: Path) -> None:
    """One timed run of the bare loop (one process): prints a JSON line."""
    from pardem.core.state import FREE
    from pardem.simulation import Simulation

    run = Simulation(scene_of(scene, False), restart=ckpt)
    past_two_builds(run)  # the state pardem's worker starts timing from
    ps, pairs, prm = run.ps, run.pairs, run.prm
    n = run.clock.n_local[0]
    m = pairs.count[0]
    arrays = dict(x=ps.x[:n].copy(), v=ps.v[:n].copy(), w=ps.omega[:n].copy(),
                  f=ps.f[:n].copy(), tau=ps.tau[:n].copy(), radius=ps.radius[:n].copy(),
                  inv_m=ps.inv_mass[:n].copy(), inv_i=ps.inv_inertia[:n].copy(),
                  free=np.flatnonzero(ps.kind[:n] == FREE).astype(np.int64),
                  pi=pairs.i[:m].astype(np.int64), pj=pairs.j[:m].astype(np.int64),
                  hist=np.ascontiguousarray(pairs.hist[:m, -2:]))
    law = prm.law
    params = (prm.dt, law.k_n, law.gamma_n, law.k_t, law.mu, prm.mu_b_g)
    def fresh() -> list:  # the start state, copied
        return [a.copy() for a in arrays.values()]

    bare_steps(*fresh(), params, 200)  # compiled (or loaded) and caches warm
    # without the flat ring and the rings' motion the packing relaxes (a quarter fewer
    # touching pairs after 10,000 steps of B in steady shear), which would flatter the loop:
    # it runs in chunks of CHUNK steps, each from the start state again (copied untimed)
    start = bare_steps(*fresh(), params, 1)
    wall, end, left = 0.0, 0, steps
    while left > 0:
        state = fresh()
        t0 = time.perf_counter()
        end = bare_steps(*state, params, min(CHUNK, left))
        wall += time.perf_counter() - t0
        left -= CHUNK
    print(json.dumps({"wall": wall, "n_free": int(arrays["free"].size), "pairs": int(m),
                      "touching_start": start / m, "touching_end": end / m}))


def bare_run(ckpt: Path, steps: int, scene: Path, env: dict) -> dict:
    """One timed run of the bare loop in a fresh process: its JSON line, with ``rate``
    (flow-particle-steps/s)."""
    out = subprocess.run([sys.executable, __file__, "--worker", str(ckpt), "--steps", str(steps),
                          "--scene", str(scene)], check=True, capture_output=True, text=True,
                         env=env, timeout=3600)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["rate"] = res["n_free"] * steps / res["wall"]
    return res


def one_core_parser(doc: str) -> argparse.ArgumentParser:
    """The options of the one-core comparisons (this script and vs_lammps.py)."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--steps", type=int, default=10000)
    ap.add_argument("--at", type=float, default=2.5, help="s: the state pardem starts from "
                    "(default: just after the compression)")
    ap.add_argument("--scene", type=Path, default=SCENE, help="pardem's scene (default B)")
    ap.add_argument("--checkpoint", type=Path, metavar="FILE",
                    help="pardem's state at --at; made if missing")
    return ap


def main() -> None:
    ap = one_core_parser(__doc__)
    ap.add_argument("--worker", metavar="CKPT", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        bare_worker(args.worker, args.steps, args.scene)
        return
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    mpiexec = Path(sys.executable).parent / "mpiexec"
    scene = args.scene.resolve()
    with tempfile.TemporaryDirectory() as tmp:
        ckpt = args.checkpoint or Path(tmp) / "compressed.h5"
        if not ckpt.exists():
            compress(ckpt, args.scene, args.at)
        ours, bare = [], []
        for k in range(args.repeats):
            res = bare_run(ckpt, args.steps, scene, env)
            bare.append(res["rate"])
            mine = _worker_run(mpiexec, ROOT, ckpt, args.steps, False, 1, env, scene)
            ours.append(mine["n_free"] * args.steps / mine["wall"])
            print(f"round {k + 1}: bare loop {bare[-1] / 1e6:.2f} M (pairs touching "
                  f"{res['touching_start']:.3f} -> {res['touching_end']:.3f} of "
                  f"{res['pairs']}), pardem {ours[-1] / 1e6:.2f} M flow-particle-steps/s: "
                  f"{ours[-1] / bare[-1]:.3f}", flush=True)
    print(f"one core, {args.steps} steps, {args.repeats} rounds (medians, range):")
    summary({"pardem": ours, "bare loop": bare}, [("pardem", "bare loop")])


def summary(rates: dict[str, list[float]], ratios: list[tuple[str, str]]) -> None:
    """Print each code's median rate (M flow-particle-steps/s) with its range, then each ratio
    (a, b) of ``ratios``: a over b, as the ratio of the medians and per round."""
    for name, r in rates.items():
        print(f"  {name}: {statistics.median(r) / 1e6:.2f} M ({min(r) / 1e6:.2f}-"
              f"{max(r) / 1e6:.2f})")
    for a, b in ratios:
        per_round = [x / y for x, y in zip(rates[a], rates[b])]
        print(f"  {a} / {b}: {statistics.median(rates[a]) / statistics.median(rates[b]):.3f} "
              f"(ratio of the medians), per round median {statistics.median(per_round):.3f}, "
              f"spread {min(per_round):.3f}-{max(per_round):.3f}")


if __name__ == "__main__":
    main()

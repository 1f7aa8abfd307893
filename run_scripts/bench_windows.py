"""Benchmark: what the memory hierarchy costs the pair loop of a large cell, on one core.

    python run_scripts/bench_windows.py SCENE.toml CHECKPOINT.h5 [SCENE CHECKPOINT ...]
                                        [--rounds 3] [--reps 3000000] [--sweep 1 2 4 8]

Per restored state, the pair loop (``forces.contact_forces`` without the flat ring contacts and
without zeroing the forces) on the whole list, and on windows of consecutive pairs of the same
list (copied out with their histories; up to 16 windows spread over the list, averaged) each
called over and over, so that a window smaller than the caches computes from them. The same
pairs and the same law: what a window of B's size costs per listed pair is what the whole list
would cost if its data stayed cached, and the growth with the window's size (7,000 pairs, B's
list, to 400,000) shows which cache level it falls out of. ``--reps``: pairs computed per
timing. Prints ns per listed pair, median (range) over the rounds, and the fraction of the
pairs with a force (the loop's own count).

``--sweep S ...``: also the whole list swept in windows of 70,000 pairs, each window's loop
called S times before the next, so that its data comes from memory once per S calls: what
advancing cache-sized blocks S steps at a time would save on memory (their borders' extra
work not included).
"""

from __future__ import annotations

import statistics
import time

import numpy as np
from bench_order import parse_states
from bench_stages import forces_loop

from pardem.forces import new_work


def window(pairs, start: int, stop: int):
    """The pairs [start, stop) of a list as a list of their own (copies)."""
    return pairs._replace(i=pairs.i[start:stop].copy(), j=pairs.j[start:stop].copy(),
                          hist=pairs.hist[start:stop].copy(), fn=pairs.fn[start:stop].copy(),
                          ft=pairs.ft[start:stop].copy(),
                          count=np.array([stop - start], pairs.count.dtype))


def per_pair(sim, pairs, reps: int) -> tuple[float, float]:
    """Seconds per listed pair of one call on ``pairs`` (after three untimed ones, which also
    let the loop choose between every pair and the selection), and the fraction with a force."""
    o = sim.options
    work = new_work(o.contact, int(pairs.count[0]))
    args = (sim.ps, pairs, 0, sim.prm, sim.time, o.contact, o.rotation, False, work)
    forces_loop(*args, 3)
    t = time.perf_counter()
    forces_loop(*args, reps)
    return (time.perf_counter() - t) / reps / int(pairs.count[0]), float(work.rows[-1])


SWEEP_WINDOW = 70_000


def sweep(sim, calls: int, rounds: int) -> list[float]:
    """Seconds per pair-call: the list swept window by window, ``calls`` calls per window,
    8 calls of every pair in all per round."""
    o, n = sim.options, int(sim.pairs.count[0])
    edges = list(range(0, n, SWEEP_WINDOW)) + [n]
    wins = [window(sim.pairs, a, b) for a, b in zip(edges[:-1], edges[1:])]
    runs = [(sim.ps, p, 0, sim.prm, sim.time, o.contact, o.rotation, False,
             new_work(o.contact, int(p.count[0]))) for p in wins]
    for r in runs:
        forces_loop(*r, 3)
    out = []
    for _ in range(rounds):
        t = time.perf_counter()
        for _ in range(max(1, 8 // calls)):
            for r in runs:
                forces_loop(*r, calls)
        out.append((time.perf_counter() - t) / (max(1, 8 // calls) * calls) / n)
    return out


def main() -> None:
    from pardem.scene import load_scene
    from pardem.simulation import Simulation

    def sweeps(ap):
        ap.add_argument("--sweep", type=int, nargs="*", default=[],
                        help="calls per window in a sweep of the whole list")

    args, states = parse_states(__doc__, 3, "--reps", 3_000_000, extra=sweeps)
    for scene, ckpt in states:
        sim = Simulation(load_scene(scene), restart=ckpt)
        n = int(sim.pairs.count[0])
        parts = {"whole list": [sim.pairs]}
        for w in (7_000, 70_000, 200_000, 400_000):
            if w < n:  # windows spread over the list, so that together they are as dense
                k = max(1, min(16, n // w))
                parts[f"{w} pairs"] = [window(sim.pairs, f, f + w)
                                       for f in np.linspace(0, n - w, k).astype(int)]
        got: dict = {k: [] for k in parts}
        for _ in range(args.rounds):
            for k, ws in parts.items():
                each = [per_pair(sim, p, max(3, args.reps // int(p.count[0]))) for p in ws]
                got[k].append((statistics.fmean(s for s, _ in each),
                               statistics.fmean(f for _, f in each)))
        print(f"{sim.scene.info.name}, t = {sim.time:.3g} s, {sim.n_free} free disks, {n} "
              f"listed pairs:", flush=True)
        for k, v in got.items():
            ns = [1e9 * s for s, _ in v]
            print(f"  {k:>14}: {statistics.median(ns):6.2f} ns per listed pair "
                  f"({min(ns):.2f}-{max(ns):.2f}), with a force {v[-1][1]:.2f}", flush=True)
        for calls in args.sweep:
            ns = [1e9 * s for s in sweep(sim, calls, args.rounds)]
            print(f"  swept in windows of {SWEEP_WINDOW}, {calls} calls each: "
                  f"{statistics.median(ns):6.2f} ns per pair ({min(ns):.2f}-{max(ns):.2f})",
                  flush=True)


if __name__ == "__main__":
    main()

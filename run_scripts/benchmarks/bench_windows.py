"""Benchmark: what the memory hierarchy costs the pair loop of a large cell, on one core.

    python run_scripts/benchmarks/bench_windows.py SCENE.toml CHECKPOINT.h5 [SCENE CHECKPOINT ...]
                                                   [--rounds 3] [--reps 3000000] [--sweep 1 2 4 8]

Per restored state (stepped twice, so that the predicted velocities and the reach of the
damping window are the step's), the pair loop on the whole list, and on windows of consecutive
pairs of the same list (copied out with their histories; up to 16 windows spread over the list,
averaged, so that together they are about as dense as the list) each called over and over, so
that a window smaller than the caches computes from them. The same pairs, the same law and the
same loop: the one ``forces.contact_forces`` chooses for the whole list (every pair, or the
selection of those that can have a force), without the flat ring contacts and without zeroing
the forces. What a window of B's size costs per listed pair is what the whole list would cost
if its data stayed cached, and the growth with the window's size (7,000 pairs, B's list, to
400,000) shows which cache level it falls out of (at 10^6 disks the copies take ~0.4 GB).
``--reps``: pairs computed per timing. Prints ns per listed pair, median (range) over the
rounds, and the fraction of the pairs with a force. The calls change the histories in place
(springs advance as in a step): a timing, not a simulation.

``--sweep S ...``: also the whole list swept in windows of 70,000 pairs, each window's loop
called S times before the next, so that its data comes from memory once per S calls: what
advancing cache-sized blocks S steps at a time would save on memory (their borders' extra
work not included).
"""

from __future__ import annotations

import os
import statistics
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numba as nb  # noqa: E402
import numpy as np  # noqa: E402
from bench_order import parse_states  # noqa: E402

from pardem.core.forces import every_pair, new_work, select_below, selected_pairs  # noqa: E402
from pardem.core.jit import JIT  # noqa: E402

WINDOWS = (7_000, 70_000, 200_000, 400_000)
SWEEP_WINDOW = 70_000


@nb.njit(**dict(JIT, cache=False))
def pair_loop(ps, pairs, prm, reach, o, rotation, work, dense, reps):
    for _ in range(reps):
        if dense:
            every_pair(ps, pairs, prm, reach, o, rotation, work.rows, False, False, work.deep)
        else:
            selected_pairs(ps, pairs, prm, reach, o, rotation, work, False)


@nb.njit(**dict(JIT, cache=False))
def force_fraction(ps, pairs, prm, reach, o, rotation, work):
    return every_pair(ps, pairs, prm, reach, o, rotation, work.rows, False, True, work.deep)


def window(pairs, start: int, stop: int):
    """The pairs [start, stop) of a list as a list of their own (copies)."""
    return pairs._replace(i=pairs.i[start:stop].copy(), j=pairs.j[start:stop].copy(),
                          hist=pairs.hist[start:stop].copy(), fn=pairs.fn[start:stop].copy(),
                          ft=pairs.ft[start:stop].copy(),
                          count=np.array([stop - start], pairs.count.dtype))


class Loop:
    """The pair loop of one restored state, with the whole list's choice of loop."""

    def __init__(self, sim):
        self.sim, o = sim, sim.options
        self.fixed = (sim.prm, float(sim.clock.reach[0]), o.contact, o.rotation)
        self.fraction = self.force_fraction(sim.pairs)
        self.dense = self.fraction >= select_below(int(sim.pairs.count[0]))

    def force_fraction(self, pairs) -> float:
        work = new_work(self.sim.options.contact, int(pairs.count[0]))
        return float(force_fraction(self.sim.ps, pairs, *self.fixed, work))

    def prepared(self, pairs):
        """The arguments of pair_loop for ``pairs``, after three untimed calls."""
        work = new_work(self.sim.options.contact, int(pairs.count[0]))
        args = (self.sim.ps, pairs, *self.fixed, work, self.dense)
        pair_loop(*args, 3)
        return args

    def per_pair(self, pairs, reps: int) -> float:
        """Seconds per listed pair, ``reps`` calls on ``pairs``."""
        args = self.prepared(pairs)
        t = time.perf_counter()
        pair_loop(*args, reps)
        return (time.perf_counter() - t) / reps / int(pairs.count[0])

    def sweep(self, calls: int, rounds: int) -> list[float]:
        """Seconds per pair and call: the list swept window by window, ``calls`` calls per
        window, max(1, 8 // calls) sweeps per round."""
        n = int(self.sim.pairs.count[0])
        edges = list(range(0, n, SWEEP_WINDOW)) + [n]
        runs = [self.prepared(window(self.sim.pairs, a, b)) for a, b in zip(edges, edges[1:])]
        sweeps, out = max(1, 8 // calls), []
        for _ in range(rounds):
            t = time.perf_counter()
            for _ in range(sweeps):
                for r in runs:
                    pair_loop(*r, calls)
            out.append((time.perf_counter() - t) / (sweeps * calls) / n)
        return out


def report(label: str, seconds: list[float], fraction: str = "") -> None:
    ns = [1e9 * s for s in seconds]
    print(f"  {label:>38}: {statistics.median(ns):6.2f} ns per listed pair "
          f"({min(ns):.2f}-{max(ns):.2f}){fraction}", flush=True)


def main() -> None:
    from pardem.input.scene_file import load_scene
    from pardem.simulation import Simulation

    def sweeps(ap):
        ap.add_argument("--sweep", type=int, nargs="*", default=[],
                        help="calls per window in a sweep of the whole list")

    args, states = parse_states(__doc__, 3, "--reps", 3_000_000, extra=sweeps)
    for scene, ckpt in states:
        sim = Simulation(load_scene(scene), restart=ckpt)
        sim.advance_steps(2)
        n = int(sim.pairs.count[0])
        if n == 0:
            print(f"{sim.scene.info.name}: no listed pairs, nothing to time")
            continue
        loop = Loop(sim)
        print(f"{sim.scene.info.name}, t = {sim.time:.3g} s, {sim.n_free} free disks, {n} "
              f"listed pairs, {loop.fraction:.2f} with a force: "
              f"{'every pair' if loop.dense else 'the selecting loop'}", flush=True)
        parts = {"whole list": [sim.pairs]}
        for w in (w for w in WINDOWS if w < n):
            parts[f"windows of {w} pairs"] = [
                window(sim.pairs, f, f + w)
                for f in np.linspace(0, n - w, max(1, min(16, n // w))).astype(int)]
        got: dict = {k: [] for k in parts}
        for _ in range(args.rounds):  # the parts alternate within each round
            for k, ps in parts.items():
                got[k].append(statistics.fmean(
                    loop.per_pair(p, max(3, args.reps // int(p.count[0]))) for p in ps))
        for k, ps in parts.items():
            fraction = statistics.fmean(loop.force_fraction(p) for p in ps)
            report(f"{k} ({len(ps)})" if len(ps) > 1 else k, got[k],
                   f", with a force {fraction:.2f}")
        for calls in args.sweep if n > SWEEP_WINDOW else ():  # else one window: the list
            report(f"swept in {SWEEP_WINDOW}-pair windows, x{calls}",
                   loop.sweep(calls, args.rounds))


if __name__ == "__main__":
    main()

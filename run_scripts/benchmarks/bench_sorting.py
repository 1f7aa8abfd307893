"""Benchmark: ordering the rows at an exchange, numba's np.argsort against sorted_runs.run_order,
on the shapes an exchange produces, at growing row counts.

    python run_scripts/benchmarks/bench_sorting.py [--sizes 15000 30000 60000 300000] [--repeats 7]

Shapes (int64 keys, one compiled call each, the median and range of ``--repeats`` calls):
- ``owned + arrivals``: a rank's kept owned gids (ascending, 1 % of them gone) followed by 1 %
  new gids from a neighbour (ascending, interleaved with the kept ones): 2 runs.
- ``history + springs``: a sorted (lo << 32 | hi) table followed by 1 % springs from each of 3
  ranks, each sorted: 4 runs.
Prints per size and shape the seconds of quicksort (numba's default argsort, which the
exchange used), mergesort, and run_order, and the ratio quicksort / run_order; checks that the
permutations agree.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numba as nb
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from pardem.core.sorted_runs import run_order  # noqa: E402


@nb.njit(cache=True)
def quicksort(keys):
    return np.argsort(keys)


@nb.njit(cache=True)
def mergesort(keys):
    return np.argsort(keys, kind="mergesort")


@nb.njit(cache=True)
def merged(keys):
    return run_order(keys, keys.size)


def shapes(n: int, rng) -> dict[str, np.ndarray]:
    kept = np.sort(rng.choice(np.arange(2 * n), n - n // 100, replace=False))
    arriving = np.sort(rng.choice(np.setdiff1d(np.arange(2 * n), kept), n // 100,
                                  replace=False))
    lo = np.sort(rng.integers(0, n, n))
    table = np.unique((lo << 32) | (lo + 1 + rng.integers(0, 50, n)))
    springs = [np.sort(rng.choice(table, n // 100)) for _ in range(3)]
    return {"owned + arrivals": np.concatenate([kept, arriving]).astype(np.int64),
            "history + springs": np.concatenate([table, *springs]).astype(np.int64)}


def timed(fn, keys, repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(keys)
        out.append(time.perf_counter() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[15_000, 30_000, 60_000, 300_000])
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    rng = np.random.default_rng(1)
    for fn in (quicksort, mergesort, merged):  # compile outside the clock
        fn(np.arange(3, dtype=np.int64))
    print("| rows | shape | quicksort ms | mergesort ms | run_order ms | quicksort / run_order |")
    print("|---|---|---|---|---|---|")
    for n in args.sizes:
        for name, keys in shapes(n, rng).items():
            stable = np.argsort(keys, kind="stable")
            assert np.array_equal(merged(keys), stable), "run_order differs from a stable sort"
            times = {fn.__name__: timed(fn, keys, args.repeats)
                     for fn in (quicksort, mergesort, merged)}
            med = {k: statistics.median(v) for k, v in times.items()}
            cells = [f"{1e3 * med[k]:.2f} ({1e3 * min(v):.2f}–{1e3 * max(v):.2f})"
                     for k, v in times.items()]
            print(f"| {keys.size} | {name} | " + " | ".join(cells)
                  + f" | {med['quicksort'] / med['merged']:.1f} |", flush=True)


if __name__ == "__main__":
    main()

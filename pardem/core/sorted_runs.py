"""Ordering keys that arrive as a few ascending runs, in O(n log runs).

Stage: neighbour rebuild and exchange. Rows are stored as a few gid-ascending runs (owned
particles; wall disks; ghosts by owner), a history table is sorted and the springs that arrive
from each rank are sorted too; what needs ordering is their concatenation. numba's
``np.argsort`` (quicksort) is super-linear on such input (3.1 / 12.4 / 48.5 ms at 15k / 30k /
60k rows: an ascending run followed by a few smaller keys) and one of the dearest functions to
compile; merging the runs pairwise costs n per round and log2(runs) rounds.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .jit import JIT, copy_values


@nb.njit(**JIT)
def run_order(keys, n):
    """Indices of keys[:n] in ascending order, stable (equal keys keep their order): the
    ascending runs of keys[:n] merged pairwise. The same permutation as a stable argsort."""
    starts = np.empty(n + 1, np.int64)  # run r is a[starts[r]:starts[r + 1]]
    starts[0] = 0
    runs = 0
    for k in range(1, n):
        if keys[k] < keys[k - 1]:
            runs += 1
            starts[runs] = k
    runs += 1 if n > 0 else 0
    starts[runs] = n
    # int32 indices (a rank's rows are int32-indexed anyway, as in Pairs): the two index
    # arrays are a neighbour build's largest temporaries after the cell copies
    a = np.empty(n, np.int32)
    for k in range(n):
        a[k] = k
    b = np.empty(n, np.int32)
    while runs > 1:
        merged = 0
        for r in range(0, runs, 2):
            first, mid = starts[r], starts[r + 1]
            last = starts[r + 2] if r + 2 <= runs else mid  # odd run out: copied
            p, q, o = first, mid, first
            while p < mid and q < last:
                if keys[a[q]] < keys[a[p]]:  # ties: the earlier run first (stable)
                    b[o] = a[q]
                    q += 1
                else:
                    b[o] = a[p]
                    p += 1
                o += 1
            copy_values(b[o:o + mid - p], a[p:mid])
            o += mid - p
            copy_values(b[o:o + last - q], a[q:last])
            starts[merged] = first
            merged += 1
        starts[merged] = n
        runs = merged
        a, b = b, a
    return a


@nb.njit(**JIT)
def merge_slots(a, b, b_order):
    """Where each key goes when the ascending keys ``a`` and the keys ``b`` (ascending in the
    order ``b_order``) are merged into one ascending sequence, no key in both: returns
    ``(slot_a, slot_b)``, slot_b in b_order's order."""
    slot_a = np.empty(a.size, np.int64)
    slot_b = np.empty(b_order.size, np.int64)
    i, j = 0, 0
    while i < a.size or j < b_order.size:
        if j < b_order.size and (i == a.size or b[b_order[j]] < a[i]):
            slot_b[j] = i + j
            j += 1
        else:
            slot_a[i] = i + j
            i += 1
    return slot_a, slot_b

"""Contact history keyed by particle-id pairs: what survives a neighbour build, a migration and a
checkpoint.

Stage: neighbour rebuild. A pair list stores one history row per pair (``model.history_columns``:
spring, rolling spring, eta), aligned with the list. Outside a list, the history is a sorted
table ``(gid_lo, gid_hi, rows)``: ``live_history`` takes it from a list, ``carry_history`` puts
it into a new list, ``merge_history`` joins tables from several ranks (LAMMPS keeps its
``fix neigh/history`` the same way: per partner id, migrated with the atom).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..core.jit import JIT, copy_values
from ..core.sorted_runs import run_order

SHIFT, LOW = 32, (1 << 32) - 1  # a pair's sort key: (gid_lo << 32) | gid_hi; gids < 2**31


@nb.njit(**JIT)
def carry_history(old_lo, old_hi, old_xi, gid, pi, pj, new_xi, first=0):
    """Copy history rows from a table keyed by (lo, hi) gids and sorted by them, to the pairs
    (pi, pj) of a new list (local indices, gid-sorted); absent pairs start with zeros. Columns
    ``first`` onwards of ``old_xi``, as many as ``new_xi`` has (a table's columns go to two
    arrays without a copy of the table)."""
    p = 0
    n_old = old_lo.size
    for k in range(new_xi.shape[0]):
        lo = gid[pi[k]]
        hi = gid[pj[k]]
        while p < n_old and (old_lo[p] < lo or (old_lo[p] == lo and old_hi[p] < hi)):
            p += 1
        found = p < n_old and old_lo[p] == lo and old_hi[p] == hi
        for c in range(new_xi.shape[1]):
            new_xi[k, c] = old_xi[p, first + c] if found else 0.0


@nb.njit(**JIT)
def live_history(gid, pi, pj, xi, count):
    """The non-zero history rows of a list as ``(gid_lo, gid_hi, rows [m, columns])``, in list
    (key) order (a pair whose columns are all zero does not touch: nothing to keep)."""
    w = xi.shape[1]
    live = np.zeros(count, np.bool_)
    for k in range(count):
        for c in range(w):
            live[k] |= xi[k, c] != 0.0
    m = int(live.sum())
    lo = np.empty(m, np.int64)
    hi = np.empty(m, np.int64)
    out = np.empty((m, w))
    q = 0
    for k in range(count):
        if live[k]:
            lo[q] = gid[pi[k]]
            hi[q] = gid[pj[k]]
            copy_values(out[q], xi[k])
            q += 1
    return lo, hi, out


@nb.njit(**JIT)
def merge_history(lo, hi, xi, rows):
    """A history table (lo, hi, xi [m, w]), sorted by (lo, hi), joined with more rows
    [m', 2 + w] (lo, hi, the w columns; any order), sorted by (lo, hi), duplicates dropped (a
    pair seen by two ranks has the same history on both: same inputs, same arithmetic; the
    table's row is kept, then the first of the rows). The rows are few (a migration's springs)
    and only they are sorted: the table goes through once, without a sorted copy of it, since
    at 10^6 disks such copies were an exchange's peak memory."""
    w = rows.shape[1] - 2
    n_t, n_r = lo.size, rows.shape[0]
    rkey = np.empty(n_r, np.int64)
    for k in range(n_r):
        rkey[k] = (int(rows[k, 0]) << SHIFT) | int(rows[k, 1])
    rorder = run_order(rkey, n_r)
    out_lo = np.empty(n_t + n_r, np.int64)
    out_hi = np.empty(n_t + n_r, np.int64)
    out_xi = np.empty((n_t + n_r, w))
    m, p, q, last, prev = 0, 0, 0, -1, -1  # prev: the table's previous key
    while p < n_t or q < n_r:
        tkey = (lo[p] << SHIFT) | hi[p] if p < n_t else -1
        if p < n_t and (q == n_r or tkey <= rkey[rorder[q]]):  # ties: the table's row first
            if tkey < prev:
                raise ValueError("merge_history: the history table is not sorted by key")
            key, row, prev = tkey, xi[p], tkey
            p += 1
        else:
            key, row = rkey[rorder[q]], rows[rorder[q], 2:]
            q += 1
        if key != last:
            out_lo[m] = key >> SHIFT
            out_hi[m] = key & LOW
            copy_values(out_xi[m], row)
            m += 1
            last = key
    return out_lo[:m], out_hi[:m], out_xi[:m]


NO_HISTORY = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)))
"""An empty history table (gid_lo, gid_hi, rows)."""


def tracks_eta(scene, writes_output: bool) -> bool:
    """Whether a run keeps the paper's total tangential displacement eta (eq. 1.3) per contact:
    only with tangential friction, and only where something reads it: in-situ averaging with
    [averaging] displacement = "eta", or contacts written with the snapshots
    (offline averaging may use either). Otherwise the step loop is compiled without it."""
    if not scene.effects.tangential_friction:
        return False
    avg = scene.averaging
    return ((writes_output and scene.output.contacts)
            or (avg is not None and scene.geometry is not None and avg.displacement == "eta"))

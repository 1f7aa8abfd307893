"""Cell-list pairs equal brute-force pairs; history is carried by gid keys."""

import numpy as np
import pytest

from pardem.contact.history import carry_history, merge_history
from pardem.core.neighbors import build_pairs
from pardem.core.sorted_runs import run_order
from pardem.testing import brute_force_pairs


def random_dense(n, seed):
    rng = np.random.default_rng(seed)
    side = np.sqrt(n) * 7e-3
    x = rng.uniform(0, side, (n, 2))
    radius = rng.choice([3.71e-3, 4.495e-3, 1.25e-3], n)
    gid = rng.permutation(n).astype(np.int64)  # storage order is not gid order
    kind = (rng.uniform(size=n) < 0.1).astype(np.int8)
    order = np.argsort(kind, kind="stable")  # moving particles first, as in the engine
    return x[order], radius[order], gid[order], kind[order]


def test_cell_list_equals_brute_force():
    for seed in range(5):
        x, r, gid, kind = random_dense(800, seed)
        skin = 0.7e-3
        pi = np.zeros(16, np.int32)
        pj = np.zeros(16, np.int32)
        n_own = int((kind == 0).sum())
        count = build_pairs(x, r, gid, n_own, n_own, x.shape[0], skin, 0.0, pi, pj)
        assert count > 16  # capacity overflow reported, then grown
        pi = np.zeros(count, np.int32)
        pj = np.zeros(count, np.int32)
        assert build_pairs(x, r, gid, n_own, n_own, x.shape[0], skin, 0.0, pi, pj) == count
        keys = list(zip(gid[pi].tolist(), gid[pj].tolist()))
        assert set(keys) == brute_force_pairs(x, r, gid, kind, skin)
        assert len(keys) == len(set(keys))
        assert keys == sorted(keys)  # canonical order: (lower gid, higher gid), sorted
        assert all(a < b for a, b in keys)


def test_wall_pairs_reach_wall_skin_farther():
    """Rows n_own:n_local are wall disks (gids above every free disk's, as in a cell, where
    free disks come first): a free particle and a wall disk are listed within
    a + a' + skin + wall_skin, free pairs (owned or ghost partners) within a + a' + skin; no
    wall-wall, ghost-ghost or ghost-wall pairs. Brute force over all pairs."""
    for seed in range(5):
        x, r, gid, kind = random_dense(800, seed)
        n_own = int((kind == 0).sum())
        n_local = n_own + (x.shape[0] - n_own) // 2  # the rest: ghosts
        skin, wall_skin = 0.7e-3, 1.4e-3
        role = np.where(np.arange(x.shape[0]) < n_own, 0,
                        np.where(np.arange(x.shape[0]) < n_local, 1, 2))  # own, wall, ghost
        # numbered as a cell numbers them: every wall disk after every free disk
        gid = gid + (role == 1) * (gid.max() + 1)
        pi = np.zeros(40000, np.int32)
        pj = np.zeros(40000, np.int32)
        count = build_pairs(x, r, gid, n_own, n_local, x.shape[0], skin, wall_skin, pi, pj)
        got = set(zip(gid[pi[:count]].tolist(), gid[pj[:count]].tolist()))
        want = set()
        for i in range(x.shape[0]):
            for j in range(x.shape[0]):
                if gid[i] >= gid[j] or (role[i] != 0 and role[j] != 0):
                    continue
                extra = wall_skin if 1 in (role[i], role[j]) else 0.0
                if np.hypot(*(x[i] - x[j])) < r[i] + r[j] + skin + extra:
                    want.add((int(gid[i]), int(gid[j])))
        assert got == want
        assert any(1 in (role[i], role[j]) for i, j in zip(pi[:count], pj[:count])
                   if np.hypot(*(x[i] - x[j])) > r[i] + r[j] + skin)  # the extra reach is used


def test_carry_history_matches_by_gid_keys():
    old_lo = np.array([0, 0, 2, 5])
    old_hi = np.array([1, 3, 4, 6])
    old_xi = np.arange(8.0).reshape(4, 2)
    gid = np.array([10, 0, 1, 2, 3, 4, 5, 6, 7])  # local index -> gid (storage order differs)
    new_lo = np.array([1, 2, 3, 6, 6])  # local indices of the pairs (0, 3), (1, 2), ...
    new_hi = np.array([4, 3, 5, 7, 8])
    new_xi = np.full((5, 2), -1.0)
    carry_history(old_lo, old_hi, old_xi, gid, new_lo, new_hi, new_xi)
    np.testing.assert_array_equal(new_xi, [[2, 3], [0, 0], [4, 5], [6, 7], [0, 0]])


def test_carry_history_takes_columns_from_an_offset():
    """A table's columns into two arrays: the ones a list's forces (fn, ft) are restored into."""
    lo, hi = np.array([0, 2]), np.array([1, 4])
    table = np.arange(6.0).reshape(2, 3)  # (fn, ftx, fty) per pair
    gid = np.arange(5)
    pi, pj = np.array([0, 1, 2]), np.array([1, 2, 4])
    fn, ft = np.full((3, 1), -1.0), np.full((3, 2), -1.0)
    carry_history(lo, hi, table, gid, pi, pj, fn)
    carry_history(lo, hi, table, gid, pi, pj, ft, 1)
    np.testing.assert_array_equal(fn[:, 0], [0, 0, 3])
    np.testing.assert_array_equal(ft, [[1, 2], [0, 0], [4, 5]])


def test_merge_history_joins_a_sorted_table_and_rows_in_any_order():
    """Against a dictionary filled in the documented precedence: the table's rows (the first of
    a repeated key), then the rows in their given order; output sorted by (lo, hi)."""
    rng = np.random.default_rng(7)
    pairs = sorted({(int(a), int(a + b)) for a, b in rng.integers(1, 40, (120, 2))})
    table = pairs[::2] + [pairs[4]]  # one key twice, as in tables gathered from two ranks
    table.sort()
    lo, hi = (np.array(c, np.int64) for c in zip(*table))
    xi = rng.normal(size=(len(table), 3))
    keys = [pairs[k] for k in rng.integers(0, len(pairs), 60)]  # new keys, table keys, repeats
    rows = np.column_stack([np.array(keys, float), rng.normal(size=(60, 3))])
    want = {}
    for key, row in list(zip(table, xi)) + [(k, r[2:]) for k, r in zip(keys, rows)]:
        want.setdefault(key, row)
    got_lo, got_hi, got_xi = merge_history(lo, hi, xi, rows)
    assert list(zip(got_lo.tolist(), got_hi.tolist())) == sorted(want)
    np.testing.assert_array_equal(got_xi, np.array([want[k] for k in sorted(want)]))
    empty = merge_history(lo[:0], hi[:0], xi[:0], rows[:0])
    assert empty[0].size == empty[1].size == empty[2].shape[0] == 0
    with pytest.raises(ValueError, match="not sorted"):
        merge_history(lo[::-1].copy(), hi[::-1].copy(), xi[::-1].copy(), rows[:0])


def test_run_order_sorts_any_number_of_ascending_runs_stably():
    """The permutation of numpy's stable sort, for unique keys (gids) and for repeated keys
    (history tables whose pair was sent by two ranks: the first occurrence stays first)."""
    rng = np.random.default_rng(3)
    for runs in [1, 2, 3, 4, 7, 50, 1000]:
        for keys in (rng.permutation(1000), rng.integers(0, 60, 1000)):
            cuts = np.sort(rng.choice(np.arange(1, 1000), runs - 1, replace=False))
            keys = np.concatenate([np.sort(part) for part in np.split(keys.astype(np.int64),
                                                                      cuts)])
            np.testing.assert_array_equal(run_order(keys, 1000),
                                          np.argsort(keys, kind="stable"))
            np.testing.assert_array_equal(run_order(keys, 400),
                                          np.argsort(keys[:400], kind="stable"))
    assert run_order(np.zeros(0, np.int64), 0).size == 0
    assert run_order(np.array([5], np.int64), 1).tolist() == [0]

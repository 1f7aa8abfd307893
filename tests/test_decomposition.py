"""Decomposition helpers without MPI: sector ownership and distance against direct geometry, and
the packed rows that carry particles between ranks."""

import math

import numpy as np
import pytest

from pardem.parallel import sectors
from pardem.sorted_runs import merge_slots
from pardem.state import (FREE, move_rows, new_particles, packed, particle_fields, row_columns,
                          row_width, unpack_particles)

EDGE_SETS = {
    "2 ranks, one wedge wider than pi": [-2.0, 2.4],
    "2 ranks, wedges of exactly pi": [-math.pi, 0.0],
    "3 ranks": [-3.0, -1.0, 1.5],
    "4 ranks, one wedge 0.01 rad": [-1.0, -0.99, 0.5, 2.0],
}


def wedge_of(angle, edges):
    """Direct: the wedge [edges[r], edges[r+1]) holding the angle, wrapped to edges[0] + 2 pi."""
    rel = (angle - edges[0]) % (2 * math.pi)
    return [r for r in range(len(edges) - 1)
            if edges[r] - edges[0] <= rel < edges[r + 1] - edges[0]]


@pytest.mark.parametrize("name", EDGE_SETS)
def test_owner_is_the_wedge_holding_the_point(name):
    cuts = EDGE_SETS[name]
    sec = sectors.Sectors(np.array(cuts + [cuts[0] + 2 * math.pi]))
    rng = np.random.default_rng(3)
    phi = rng.uniform(-math.pi, math.pi, 4000)
    r = rng.uniform(0.01, 0.2, phi.size)
    x = np.column_stack([r * np.cos(phi), r * np.sin(phi)])
    # points within 1e-9 rad of an edge may go either way (rounding); leave them out
    gap = np.min(np.abs((phi[:, None] - sec.edges[None, :] + math.pi) % (2 * math.pi) - math.pi),
                 axis=1)
    x, phi = x[gap > 1e-9], phi[gap > 1e-9]
    expected = np.array([wedge_of(math.atan2(p[1], p[0]), sec.edges)[0] for p in x])
    for guess in range(sec.count):  # the fast test of the guessed wedge, then the fallback
        np.testing.assert_array_equal(sec.owner(x, guess), expected)
    assert set(expected) == set(range(sec.count))


@pytest.mark.parametrize("name", EDGE_SETS)
def test_distance_is_to_the_nearest_boundary_ray(name):
    cuts = EDGE_SETS[name]
    sec = sectors.Sectors(np.array(cuts + [cuts[0] + 2 * math.pi]))
    x = np.random.default_rng(4).uniform(-0.2, 0.2, (3000, 2))

    def ray(angle):  # direct: distance to the nearest point t e, t >= 0
        e = np.array([math.cos(angle), math.sin(angle)])
        t = np.maximum(x @ e, 0.0)
        return np.linalg.norm(x - t[:, None] * e, axis=1)

    for rank in range(sec.count):
        expected = np.minimum(ray(sec.edges[rank]), ray(sec.edges[rank + 1]))
        np.testing.assert_allclose(sec.distance(x, rank), expected, rtol=1e-12, atol=1e-17)


@pytest.mark.parametrize("hist", [0, 2, 3, 5])
def test_packed_rows_come_back_unchanged(hist):
    ps = new_particles(50, hist)
    rng = np.random.default_rng(5)
    for k in particle_fields(hist):
        v = getattr(ps, k)
        if v.dtype == np.float64:
            v[...] = rng.normal(size=v.shape) * 10.0 ** rng.integers(-300, 300, v.shape)
    ps.gid[:] = rng.integers(0, 2**53, 50)  # ids are exact in float64 up to 2**53
    ps.kind[:] = rng.integers(FREE, 3, 50)
    cols = row_columns(hist)
    for idx in (np.array([7, 3, 3, 49, 0]), np.zeros(0, np.int64)):
        rows = packed(ps, idx, hist)
        assert rows.shape == (idx.size, row_width(hist))
        for k, c in cols.items():  # each array in its documented columns
            v = getattr(ps, k)
            np.testing.assert_array_equal(rows[:, c].reshape((idx.size,) + v.shape[1:]), v[idx])
        back = new_particles(idx.size + 4, hist)
        unpack_particles(rows, back, 2)
        for k in particle_fields(hist):
            assert getattr(back, k).dtype == getattr(ps, k).dtype
            np.testing.assert_array_equal(getattr(back, k)[2:2 + idx.size], getattr(ps, k)[idx])
            assert not getattr(back, k)[:2].any() and not getattr(back, k)[2 + idx.size:].any()
    assert not hist or cols["hist_wall"].stop == row_width(hist)
    assert not hist or cols["hist_wall"].stop - cols["hist_wall"].start == hist


@pytest.mark.parametrize("seed", range(6))
def test_owned_rows_moved_in_place_equal_the_sorted_union(seed):
    """An exchange's new owned block, [kept rows and arrivals, by gid], made in place
    (merge_slots + move_rows) equals numpy's stable sort of their packed rows: leavers
    anywhere, arrivals before, between and after the kept gids, the block growing into the
    rows after it or shrinking, and the rows after the new block untouched."""
    rng = np.random.default_rng(seed)
    hist, n, cap = 3, 300, 700
    ps = new_particles(cap, hist)
    for k in particle_fields(hist):
        v = getattr(ps, k)
        if v.dtype == np.float64:
            v[...] = rng.normal(size=v.shape)
    pool = rng.choice(10**6, n + 200, replace=False)
    ps.gid[:n] = np.sort(pool[:n])
    ps.gid[n:] = -1
    ps.kind[:] = rng.integers(FREE, 3, cap)
    kept = np.sort(rng.choice(n, int(n * rng.uniform(0.5, 1.0)), replace=False))
    n_arr = int(rng.integers(0, 200))
    arrivals = rng.normal(size=(n_arr, row_width(hist)))
    arrivals[:, row_columns(hist)["gid"]] = pool[n:n + n_arr, None]
    arrivals[:, row_columns(hist)["kind"]] = rng.integers(FREE, 3, (n_arr, 1))
    senders = np.sort(rng.choice(np.arange(1, n_arr), min(2, max(n_arr - 1, 0)), replace=False))
    for part in np.split(np.arange(n_arr), senders):  # each sender's arrivals ascend
        arrivals[part] = arrivals[part[np.argsort(arrivals[part, 0])]]
    expected = np.concatenate([packed(ps, kept, hist), arrivals])
    expected = expected[np.argsort(expected[:, 0], kind="stable")]
    after = packed(ps, np.arange(expected.shape[0], cap), hist)

    arr_gid = arrivals[:, 0].astype(np.int64)
    order = np.argsort(arr_gid, kind="stable")
    at_kept, at_arr = merge_slots(ps.gid[kept], arr_gid, order)
    move_rows(ps, kept, at_kept, arrivals, order, at_arr)
    np.testing.assert_array_equal(packed(ps, np.arange(expected.shape[0]), hist), expected)
    np.testing.assert_array_equal(packed(ps, np.arange(expected.shape[0], cap), hist), after)

"""Decomposition helpers without MPI: ownership of sectors and rings of sectors and the distance
to them against direct geometry, the choice of the cut, and the packed rows that carry particles
between ranks."""

import math

import numpy as np
import pytest

from pardem.parallel import choice, cut
from pardem.core.sorted_runs import merge_slots
from pardem.core.state import (FREE, move_rows, new_particles, packed, particle_fields, row_columns,
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
    sec = cut.sectors(np.array(cuts + [cuts[0] + 2 * math.pi]))
    edges = sec.edges[0]
    rng = np.random.default_rng(3)
    phi = rng.uniform(-math.pi, math.pi, 4000)
    r = rng.uniform(0.01, 0.2, phi.size)
    x = np.column_stack([r * np.cos(phi), r * np.sin(phi)])
    # points within 1e-9 rad of an edge may go either way (rounding); leave them out
    gap = np.min(np.abs((phi[:, None] - edges[None, :] + math.pi) % (2 * math.pi) - math.pi),
                 axis=1)
    x, phi = x[gap > 1e-9], phi[gap > 1e-9]
    expected = np.array([wedge_of(math.atan2(p[1], p[0]), edges)[0] for p in x])
    for guess in range(sec.count):  # the fast test of the guessed wedge, then the fallback
        np.testing.assert_array_equal(sec.owner(x, guess), expected)
    assert set(expected) == set(range(sec.count))


@pytest.mark.parametrize("name", EDGE_SETS)
def test_distance_is_to_the_nearest_boundary_ray(name):
    cuts = EDGE_SETS[name]
    sec = cut.sectors(np.array(cuts + [cuts[0] + 2 * math.pi]))
    points = np.random.default_rng(4).uniform(-0.2, 0.2, (3000, 2))

    def ray(angle):  # direct: distance to the nearest point t e, t >= 0
        e = np.array([math.cos(angle), math.sin(angle)])
        t = np.maximum(x @ e, 0.0)
        return np.linalg.norm(x - t[:, None] * e, axis=1)

    for rank in range(sec.count):
        x = points[sec.owner(points) != rank]  # the distance of a point outside the domain
        expected = np.minimum(ray(sec.edges[0, rank]), ray(sec.edges[0, rank + 1]))
        np.testing.assert_allclose(sec.distance(x, rank), expected, rtol=1e-12, atol=1e-17)


# rings of sectors: (ring radii inside the annulus, sector edges per ring); the outer ring runs
# to infinity and the inner one from the axis, as in a run
RING_CUTS = {
    "2 rings x 2, one wedge wider than pi": ([0.08], [[-2.0, 2.4], [-1.0, 0.5]]),
    "3 rings x 1": ([0.06, 0.12], [[-3.0], [0.2], [1.0]]),
    "2 rings x 4, one wedge 0.01 rad": ([0.1], [[-1.0, -0.99, 0.5, 2.0], [-3.0, -2.0, 0.0, 1.0]]),
}


def ring_cut(name):
    radii, starts = RING_CUTS[name]
    edges = np.array([e + [e[0] + 2 * math.pi] for e in starts])
    return cut.Cut(np.array([0.0] + radii + [math.inf]), edges)


def annulus_points(n, seed, r_in=0.02, r_out=0.2):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(-math.pi, math.pi, n)
    r = rng.uniform(r_in, r_out, n)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi)]), r, phi


@pytest.mark.parametrize("name", RING_CUTS)
def test_owner_of_rings_is_the_ring_and_wedge_holding_the_point(name):
    c = ring_cut(name)
    x, r, phi = annulus_points(6000, 7)
    per_ring = c.edges.shape[1] - 1
    ring = np.searchsorted(c.radii, r, side="right") - 1
    wedge = [wedge_of(p, c.edges[b]) for p, b in zip(phi, ring)]
    # points within 1e-9 of a boundary may go either way (rounding); leave them out
    clear = np.array([len(w) == 1 for w in wedge]) & (
        np.min(np.abs(r[:, None] - c.radii[None, 1:-1]), axis=1) > 1e-9)
    gap = np.min(np.abs((phi[:, None, None] - c.edges[None] + math.pi) % (2 * math.pi) - math.pi),
                 axis=(1, 2))
    clear &= gap > 1e-9
    expected = np.array([b * per_ring + w[0] for b, w in zip(ring[clear], np.array(
        wedge, dtype=object)[clear])])
    for guess in range(c.count):
        np.testing.assert_array_equal(c.owner(x[clear], guess), expected)
    assert set(expected) == set(range(c.count))


def sampled_distance(x, r0, r1, a0, a1, samples=20_000):
    """Direct: distance from each point to the nearest of many points on the boundary of the
    polar rectangle r0 <= r <= r1, a0 <= angle <= a1 (r1 capped at 1 m)."""
    r1 = min(r1, 1.0)
    a = np.linspace(a0, a1, samples)
    rr = np.linspace(r0, r1, samples)
    bx = np.concatenate([r0 * np.cos(a), r1 * np.cos(a), rr * math.cos(a0), rr * math.cos(a1)])
    by = np.concatenate([r0 * np.sin(a), r1 * np.sin(a), rr * math.sin(a0), rr * math.sin(a1)])
    return np.array([np.min(np.hypot(bx - p[0], by - p[1])) for p in x])


@pytest.mark.parametrize("name", RING_CUTS)
def test_distance_to_a_ring_sector_is_to_its_nearest_boundary_point(name):
    c = ring_cut(name)
    x, _, _ = annulus_points(400, 8, 0.0, 0.25)
    per_ring = c.edges.shape[1] - 1
    for rank in range(c.count):
        b, s = divmod(rank, per_ring)
        out = x[c.owner(x) != rank]
        got = c.distance(out, rank)
        a0, a1 = c.edges[b, s], c.edges[b, s + 1]
        if a1 - a0 >= 2 * math.pi:  # a whole ring: no radial edges
            r = np.hypot(out[:, 0], out[:, 1])
            expected = np.maximum(np.maximum(c.radii[b] - r, r - c.radii[b + 1]), 0.0)
            np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15)
            continue
        # the boundary sampled every <= 2 pi x 1 m / 20,000: the nearest sample is that close
        np.testing.assert_allclose(got, sampled_distance(out, c.radii[b], c.radii[b + 1], a0, a1),
                                   rtol=0, atol=4e-4)


def test_ghost_counts_are_the_points_outside_each_domain_within_the_width():
    c = ring_cut("2 rings x 4, one wedge 0.01 rad")
    x, _, _ = annulus_points(3000, 9)
    width = 0.01
    owner = c.owner(x)
    expected = [int(np.sum((owner != d) & (c.distance(x, d) < width))) for d in range(c.count)]
    assert list(cut.ghost_counts(x, c.radii, c.edges, width)) == expected


def uniform_annulus(n, r_in, r_out, seed=11):
    rng = np.random.default_rng(seed)
    r = np.sqrt(rng.uniform(r_in**2, r_out**2, n))  # uniform in area
    phi = rng.uniform(-math.pi, math.pi, n)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi)])


def test_auto_cut_takes_sectors_for_a_narrow_gap_and_rings_for_a_wide_one():
    """Ghosts per domain ~ width x n_A x the length of its edges inside the packing (the walls'
    arcs have no particles beyond them). In a gap L at mean radius r, each of P sectors has 2L;
    R rings of A sectors, a middle ring's domain 2 L / R + 2 x 2 pi r / A, an outer or inner
    ring's one arc less. B's gap at P = 8 (R_i 0.104 m, L 0.149 m, r ~0.19 m): sectors 0.30 m,
    2 x 4 ~0.45 m: sectors. A gap 3 times the inner radius at P = 64 (0.05 to 0.2 m, r ~0.13
    m): sectors 0.30 m, 4 x 16 or 2 x 32 ~0.18 m: rings, with clearly fewer ghosts."""
    width, reach = 0.002, 0.0015
    narrow = uniform_annulus(40_000, 0.104, 0.253)
    c, _ = choice.choose(narrow, 8, "auto", 0.104, reach, width)
    assert c.rings == 1 and c.count == 8
    wide = uniform_annulus(100_000, 0.05, 0.2)
    c, _ = choice.choose(wide, 64, "auto", 0.05, reach, width)
    sectors64 = cut.balanced(cut.angle_histogram(wide, choice.HIST_BINS), 64)
    assert c.rings > 1 and c.count == 64
    assert (cut.ghost_counts(wide, c.radii, c.edges, width).max()
            < 0.8 * cut.ghost_counts(wide, sectors64.radii, sectors64.edges, width).max())
    # every domain holds about as many points (cut at histogram bins)
    counts = np.bincount(c.owner(wide), minlength=64)
    assert counts.min() > 0.9 * counts.max()
    # up to 3 ranks sectors are taken without counting: whole rings have more ghosts even here
    for p in (2, 3):
        c, r_top = choice.choose(wide, p, "auto", 0.05, reach, width)
        rings = choice.cut_for(wide, p, p, r_top)
        assert c.rings == 1 and (cut.ghost_counts(wide, c.radii, c.edges, width).max()
                                 < cut.ghost_counts(wide, rings.radii, rings.edges, width).max())


def test_a_requested_cut_is_used_and_a_bad_one_is_refused_clearly():
    x = uniform_annulus(20_000, 0.05, 0.2)
    c, r_top = choice.choose(x, 8, "2x4", 0.05, 0.003, 0.004)
    assert (c.rings, c.count) == (2, 8) and r_top >= np.hypot(x[:, 0], x[:, 1]).max()
    c, _ = choice.choose(x, 8, "sectors", 0.05, 0.003, 0.004)
    assert (c.rings, c.count) == (1, 8)
    for text, words in (("3x3", "9 domains, but the run has 8 MPI ranks"),
                        ("rings", "expected 'auto', 'sectors' or RINGSxSECTORS"),
                        ("8x1", "narrower than the interaction reach")):
        with pytest.raises(choice.SceneError, match=words):
            choice.choose(x, 8, text, 0.05, 0.03, 0.04)
    with pytest.raises(choice.SceneError, match="too many for this cell.*use at most 10 ranks"):
        choice.choose(x, 16, "sectors", 0.05, 0.03, 0.04)


def test_a_re_cut_keeps_the_sectors_in_place_and_migrates_only_the_excess():
    """Two sectors holding n0 > n1 points are evened out by moving one edge past (n0 - n1) / 2
    points, the fewest any re-cut can migrate. Emptying a band inside sector 0 makes it the
    emptiest place of the annulus, where a first cut would start: a re-cut must not rotate the
    sectors there (which would hand over about half of every sector)."""
    x = uniform_annulus(40_000, 0.104, 0.253)
    old, r_top = choice.choose(x, 2, "sectors", 0.104, 0.003, 0.004)
    a = np.arctan2(x[:, 1], x[:, 0])
    middle = old.edges[0, 0] + 0.5 * (old.edges[0, 1] - old.edges[0, 0])
    x = x[np.abs((a - middle + math.pi) % (2 * math.pi) - math.pi) > 0.3]
    n0, n1 = np.bincount(old.owner(x), minlength=2)
    assert n0 < 0.85 * n1  # the band took ~19 % of sector 0: a re-cut is due
    new = choice.cut_for(x, 2, 1, r_top, previous=old)
    owner_new = new.owner(x)
    counts = np.bincount(owner_new, minlength=2)
    per_bin = cut.angle_histogram(x, choice.HIST_BINS).max()
    assert abs(counts[0] - counts[1]) <= 2 * per_bin
    moved = int(np.count_nonzero(owner_new != old.owner(x)))
    assert moved <= (n1 - n0) / 2 + 2 * per_bin
    # rings of sectors: each ring keeps its first edge, and the domains are evened out
    old, r_top = choice.choose(x, 4, "2x2", 0.104, 0.003, 0.004)
    new = choice.cut_for(x[x[:, 0] > -0.2], 4, 2, r_top, previous=old)
    assert np.array_equal(new.edges[:, 0], old.edges[:, 0])
    counts = np.bincount(new.owner(x[x[:, 0] > -0.2]), minlength=4)
    assert counts.min() > 0.98 * counts.max()


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
    ps.species[:] = rng.integers(0, 4, cap)
    kept = np.sort(rng.choice(n, int(n * rng.uniform(0.5, 1.0)), replace=False))
    n_arr = int(rng.integers(0, 200))
    arrivals = rng.normal(size=(n_arr, row_width(hist)))
    arrivals[:, row_columns(hist)["gid"]] = pool[n:n + n_arr, None]
    arrivals[:, row_columns(hist)["kind"]] = rng.integers(FREE, 3, (n_arr, 1))
    arrivals[:, row_columns(hist)["species"]] = rng.integers(0, 4, (n_arr, 1))
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

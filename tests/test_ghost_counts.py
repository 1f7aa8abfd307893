"""The many-rank model's inputs (run_scripts/benchmarks/ghost_counts.py): ghosts counted from
positions against closed forms, and the model's step time against its limits."""

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "run_scripts" / "benchmarks"))

import ghost_counts  # noqa: E402


def test_ghosts_of_sectors_of_a_ring_of_points_are_those_within_the_angle_of_an_edge():
    """M points on one circle at angles (k + 1/2) 2 pi / M, P equal sectors: a point of another
    sector is a ghost iff its angle to the nearer edge is below asin(w / r), so each sector
    has 2 round(asin(w / r) / delta) ghosts on its two sides (delta = 2 pi / M)."""
    m, p, r, w = 720, 8, 1.0, 0.03
    phi = (np.arange(m) + 0.5) * 2 * math.pi / m - math.pi
    x = np.column_stack([r * np.cos(phi), r * np.sin(phi)])
    edges = np.linspace(-math.pi, math.pi, p + 1)[None, :]
    owned, ghosts, nbr = ghost_counts.count(x, np.array([0.0, np.inf]), edges, w)
    per_side = math.floor(math.asin(w / r) / (2 * math.pi / m) + 0.5)
    assert per_side == 3
    np.testing.assert_array_equal(owned, m // p)
    np.testing.assert_array_equal(ghosts, 2 * per_side)
    np.testing.assert_array_equal(nbr, 2)


def lattice_annulus(r_in, r_out, h):
    """Square lattice of spacing h inside the annulus r_in <= r < r_out."""
    g = np.arange(-r_out, r_out, h) + h / 2
    x = np.array(np.meshgrid(g, g)).reshape(2, -1).T
    r = np.hypot(x[:, 0], x[:, 1])
    return x[(r >= r_in) & (r < r_out)]


def test_ghosts_of_a_sector_are_two_bands_along_its_edges_and_grow_with_the_cell():
    """A uniform density n of points in an annulus of width L cut into P sectors: each sector's
    ghosts fill two bands of width w along its radial edges, 2 n w L (up to the band's corners,
    O(w / L)); the cell scaled by k = 2 at the same density has k times as many, the law the
    model extrapolates with."""
    h, w, p = 0.01, 0.05, 8
    for k in (1, 2):
        r_in, r_out = 0.5 * k, 1.5 * k
        x = lattice_annulus(r_in, r_out, h)
        cut = ghost_counts.count_cut(x, p, 1, w)
        expected = 2 * w * (r_out - r_in) / h**2
        assert abs(cut[1].mean() / expected - 1) < 0.05, (k, cut[1].mean(), expected)


def test_model_step_is_the_compute_alone_without_ghosts_or_latency_and_adds_each_latency():
    cost = {"c_ns": 25.0, "c_g_ns": 10.0, "exchanges_per_1000_steps": 2.0}
    assert ghost_counts.step_time(1000, 0, 0, 2, cost, 0.0, np.inf) == 25e-6
    # 4 neighbours, Allreduce over 64 ranks (2 log2 64 = 12 latencies), 2 exchanges in 1000
    # steps over 63 partners: 4 + 12 + 0.126 latencies
    t = ghost_counts.step_time(1000, 100, 4, 64, cost, 1e-6, np.inf)
    assert math.isclose(t, 25e-6 + 1e-6 + (4 + 12 + 0.126) * 1e-6, rel_tol=1e-12)
    # bytes: 3 header doubles per neighbour and 5 per ghost
    t_bw = ghost_counts.step_time(1000, 100, 4, 2, cost, 0.0, 8.0)
    assert math.isclose(t_bw, 26e-6 + 3 * 4 + 5 * 100, rel_tol=1e-12)

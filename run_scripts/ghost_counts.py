"""Ghosts per rank of a Couette scene cut for P = 16 ... 1024 ranks, counted from the disks'
positions, and the step time the cost model of docs/scaling.md gives across nodes.

    python run_scripts/ghost_counts.py [SCENE] [--ranks 16 32 ... 1024] [--latency 2e-6]
                                       [--bandwidth 1e10] [--compute 27e-9]

The positions are the scene's initial placement (pardem.placement), mapped radially onto the
final annulus at constant area fraction (r^2 - R_i^2 scaled), so the density is the sheared
cell's mean; the ghost width is pardem's (largest diameter + skin + GHOST_MARGIN_SKINS skins).
Two cuts, each with P domains of equal counts:
- sectors: pardem's decomposition (``parallel.sectors.balanced`` on the same histogram);
- rings x sectors: R radial cuts at count quantiles of r, then A = P / R angular cuts per ring
  at count quantiles of the angle (the polar patches docs/scaling.md prepares; not implemented
  in pardem), R chosen among the divisors of P for the fewest ghosts.
A ghost of domain d is a disk outside d within the ghost width of it (exact distance to a
wedge or polar rectangle). Printed per P and cut: owned disks per rank, ghosts per rank (mean
and largest), neighbours (domains within the ghost width), and the modelled step time
``c N/P + c/2 G + n_nbr (latency + 40 G_nbr / bandwidth) + 2 log2(P) latency`` (compute, ghosts
at half cost, one message per neighbour carrying 5 doubles per ghost, an Allreduce of the
step's maxima), with its parallel efficiency. The latency and bandwidth are assumptions for a
cluster interconnect (defaults: 2 us, 10 GB/s), not measurements.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numba as nb
import numpy as np

from pardem.parallel.sectors import edge_distance, edge_vectors

HERE = Path(__file__).resolve().parent


@nb.njit(cache=True)
def _patch_distance(px, py, r0, r1, a0, a1):
    """Distance from (px, py) to the polar rectangle r0 <= r <= r1, a0 <= angle <= a1."""
    r = math.hypot(px, py)
    a = math.atan2(py, px)
    mid = 0.5 * (a0 + a1)
    d = (a - mid + math.pi) % (2 * math.pi) - math.pi
    if abs(d) <= 0.5 * (a1 - a0):
        return max(r0 - r, r - r1, 0.0)
    best = math.inf
    for e in (a0, a1):  # nearest point on a radial edge segment (corners included)
        ex, ey = math.cos(e), math.sin(e)
        t = min(max(px * ex + py * ey, r0), r1)
        best = min(best, math.hypot(px - t * ex, py - t * ey))
    return best


@nb.njit(cache=True)
def _count(x, ang_sorted, order, domains, edges, w):
    """Per domain (r0, r1, a0, a1; r1 = inf for a sector, ``edges`` then its edge vectors,
    ``parallel.sectors.edge_vectors``): owned disks, ghosts, and the domains whose disks it
    takes as ghosts. Candidates come from an angular window around
    the domain (``ang_sorted``: the disks' angles ascending, ``order``: their indices)."""
    n_dom = domains.shape[0]
    owned = np.zeros(n_dom, np.int64)
    ghosts = np.zeros(n_dom, np.int64)
    nbrs = np.zeros((n_dom, n_dom), np.bool_)
    r_all = np.sqrt(x[:, 0] ** 2 + x[:, 1] ** 2)
    home = np.full(x.shape[0], -1, np.int64)
    for d in range(n_dom):
        r0, r1, a0, a1 = domains[d]
        for shift in (0.0, -2 * math.pi):  # a wedge may reach past pi
            lo = np.searchsorted(ang_sorted, a0 + shift)
            hi = np.searchsorted(ang_sorted, a1 + shift)
            for q in range(lo, hi):
                k = order[q]
                if r0 <= r_all[k] < r1 and home[k] < 0:
                    home[k] = d
                    owned[d] += 1
    for d in range(n_dom):
        r0, r1, a0, a1 = domains[d]
        delta = math.asin(min(1.0, w / max(r0 - w, 1e-12))) if r0 - w > 0 else math.pi
        for shift in (-2 * math.pi, 0.0, 2 * math.pi):
            lo = np.searchsorted(ang_sorted, a0 - delta + shift)
            hi = np.searchsorted(ang_sorted, a1 + delta + shift)
            for q in range(lo, hi):
                k = order[q]
                if home[k] == d or r_all[k] < r0 - w or r_all[k] > r1 + w:
                    continue
                if math.isinf(r1):  # a sector: pardem's own distance to its edge rays
                    dist = edge_distance(x[k, 0], x[k, 1], edges, d)
                else:
                    dist = _patch_distance(x[k, 0], x[k, 1], r0, r1, a0, a1)
                if dist < w:
                    ghosts[d] += 1
                    nbrs[d, home[k]] = True
    return owned, ghosts, nbrs.sum(axis=1), home


def angular_cuts(a: np.ndarray, parts: int) -> np.ndarray:
    """Edges [parts+1] (rad) with equal counts of the angles a, starting at -pi."""
    q = np.quantile(a, np.arange(1, parts) / parts) if parts > 1 else np.zeros(0)
    return np.concatenate([[-math.pi], q, [math.pi]])


def patches(x: np.ndarray, rings: int, per_ring: int, r_in: float, r_out: float) -> np.ndarray:
    r = np.hypot(x[:, 0], x[:, 1])
    a = np.arctan2(x[:, 1], x[:, 0])
    cuts = np.concatenate([[r_in - 1.0], np.quantile(r, np.arange(1, rings) / rings),
                           [r_out + 1.0]])
    out = []
    for k in range(rings):
        inside = (r >= cuts[k]) & (r < cuts[k + 1])
        e = angular_cuts(a[inside], per_ring)
        out += [(cuts[k], cuts[k + 1], e[m], e[m + 1]) for m in range(per_ring)]
    return np.array(out)


def main() -> None:
    from pardem.parallel import GHOST_MARGIN_SKINS
    from pardem.parallel.sectors import angle_histogram, balanced
    from pardem.parallel.serial import HIST_BINS
    from pardem.placement import initial_configuration
    from pardem.scene import load_scene

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", type=Path, default=HERE / "couette_B_1M.toml")
    ap.add_argument("--ranks", type=int, nargs="+", default=[16, 32, 64, 128, 256, 512, 1024])
    ap.add_argument("--latency", type=float, default=2e-6, help="s per message (assumed)")
    ap.add_argument("--bandwidth", type=float, default=1e10, help="B/s per link (assumed)")
    ap.add_argument("--compute", type=float, default=27e-9,
                    help="s per owned disk and step (measured on B, docs/scaling.md)")
    args = ap.parse_args()
    scene = load_scene(args.scene)
    g = scene.geometry
    init = initial_configuration(scene)
    x = init.x[:init.n_free]
    r = np.hypot(x[:, 0], x[:, 1])
    r_new = np.sqrt(g.inner_radius**2 + (r**2 - g.inner_radius**2) * (
        g.outer_radius**2 - g.inner_radius**2) / (g.outer_start_radius**2 - g.inner_radius**2))
    x = x * (r_new / r)[:, None]
    r = r_new
    skin = scene.neighbors.skin or 0.1 * scene.min_free_diameter
    w = 2.0 * float(init.radius[:init.n_free].max()) + skin + GHOST_MARGIN_SKINS * skin
    n = x.shape[0]
    ang = np.arctan2(x[:, 1], x[:, 0])
    order = np.argsort(ang, kind="stable")
    ang_sorted = ang[order]
    c = args.compute
    print(f"{args.scene.name}: {n} free disks, R_i = {g.inner_radius} m, R_o = {g.outer_radius} m,"
          f" ghost width {1e3 * w:.2f} mm; latency {1e6 * args.latency:g} us, bandwidth "
          f"{args.bandwidth / 1e9:g} GB/s, compute {1e9 * c:g} ns per disk-step")
    print("| P | cut | owned / rank | ghosts / rank (mean, largest) | ghosts / owned | neighbours "
          "(largest) | modelled us / step | efficiency |")
    print("|---|---|---|---|---|---|---|---|")
    serial = c * n
    for p in args.ranks:
        edges = balanced(angle_histogram(x, HIST_BINS), p).edges
        if 2 * math.pi * g.inner_radius / p < w - GHOST_MARGIN_SKINS * skin:
            print(f"| {p} | sectors | refused: narrower than the reach at R_i | | | | | |")
            sector = None
        else:
            e = (edges + math.pi) % (2 * math.pi) - math.pi  # the first cut may wrap
            doms = np.array([(r.min() * 0.999, math.inf, e[k], e[k] + (edges[k + 1] - edges[k]))
                             for k in range(p)])
            sector = doms
        candidates = []
        if sector is not None:
            candidates.append(("sectors", sector))
        best = None
        for rings in [d for d in range(2, p + 1) if p % d == 0 and d <= 64]:
            doms = patches(x, rings, p // rings, g.inner_radius, g.outer_radius)
            owned, ghosts, nbr, _ = _count(x, ang_sorted, order, doms, np.zeros((1, 2)), w)
            if best is None or ghosts.max() < best[1][1].max():
                best = (rings, (owned, ghosts, nbr))
        rows = []
        for name, doms in candidates:
            rows.append((name, _count(x, ang_sorted, order, doms, edge_vectors(edges), w)[:3]))
        rows.append((f"{best[0]} rings x {p // best[0]}", best[1]))
        for name, (owned, ghosts, nbr) in rows:
            assert owned.sum() == n
            g_max = int(ghosts.max())
            t = (c * owned.max() + 0.5 * c * g_max
                 + nbr.max() * args.latency + 40 * g_max / args.bandwidth
                 + 2 * math.log2(p) * args.latency)
            print(f"| {p} | {name} | {owned.mean():.0f} | {ghosts.mean():.0f}, {g_max} | "
                  f"{ghosts.mean() / owned.mean():.2f} | {int(nbr.max())} | {1e6 * t:.1f} | "
                  f"{serial / (p * t):.2f} |", flush=True)


if __name__ == "__main__":
    main()

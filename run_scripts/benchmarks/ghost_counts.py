"""Ghosts per rank of a Couette scene cut for P = 16 ... 1024 ranks, counted from the disks'
positions, and the step time the cost model of docs/scaling.md gives across nodes.

    python run_scripts/benchmarks/ghost_counts.py [SCENE] [--ranks 16 32 ... 1024] [--latency 2e-6]
                                                  [--bandwidth 1e10] [--compute 27e-9]

The positions are the scene's initial placement (pardem.input.placement), mapped radially onto the
final annulus at constant area fraction (r^2 - R_i^2 scaled), so the density is the sheared
cell's mean; the ghost width is pardem's (largest diameter + skin + GHOST_MARGIN_SKINS skins).
Two cuts, each with P domains of about equal counts, as pardem cuts them
(``parallel.choice.cut_for``):
- sectors;
- R rings of A = P / R sectors, R chosen among the divisors of P for the fewest ghosts (what
  ``pardem run --cut auto`` does, here without its test of each domain's width).
A ghost of domain d is a disk outside d within the ghost width of it (pardem's own distance,
``parallel.cut.edge_distance``). Printed per P and cut: owned disks per rank, ghosts per rank (mean
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

from pardem.parallel.choice import cut_for
from pardem.parallel.cut import domain_geometry, edge_distance, owners

SCENES = Path(__file__).resolve().parents[1] / "scenes"


@nb.njit(cache=True)
def _count(x, ang_sorted, order, radii, edges, w):
    """Per domain of the cut (radii, edges; ``parallel.cut.Cut``): owned disks, ghosts, and
    the domains whose disks it takes as ghosts. Candidates come from an angular window around
    the domain (``ang_sorted``: the disks' angles ascending, ``order``: their indices)."""
    g = domain_geometry(radii, edges)
    n_dom = g.shape[0]
    per_ring = edges.shape[1] - 1
    home = owners(x, radii, edges, 0)
    owned = np.bincount(home, minlength=n_dom)
    ghosts = np.zeros(n_dom, np.int64)
    nbrs = np.zeros((n_dom, n_dom), np.bool_)
    r_all = np.sqrt(x[:, 0] ** 2 + x[:, 1] ** 2)
    r_min = r_all.min()
    for d in range(n_dom):
        b, s = d // per_ring, d % per_ring
        r0, r1 = max(radii[b], r_min), radii[b + 1]
        a0, a1 = edges[b, s], edges[b, s + 1]
        delta = math.asin(min(1.0, w / (r0 - w))) if r0 - w > 0 else math.pi
        for shift in (-2 * math.pi, 0.0, 2 * math.pi):
            lo = np.searchsorted(ang_sorted, a0 - delta + shift)
            hi = np.searchsorted(ang_sorted, a1 + delta + shift)
            for q in range(lo, hi):
                k = order[q]
                if home[k] == d or r_all[k] < r0 - w or r_all[k] > r1 + w:
                    continue
                if edge_distance(x[k, 0], x[k, 1], g, d) < w:
                    ghosts[d] += 1
                    nbrs[d, home[k]] = True
    return owned, ghosts, nbrs.sum(axis=1), home


def main() -> None:
    from pardem.parallel import GHOST_MARGIN_SKINS
    from pardem.input.placement import initial_configuration
    from pardem.input.scene_file import load_scene

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", type=Path, default=SCENES / "couette_B_1M.toml")
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
    r_top = float(r.max()) * (1.0 + 1e-9)
    for p in args.ranks:
        rows = []
        if 2 * math.pi * g.inner_radius / p < w - GHOST_MARGIN_SKINS * skin:
            print(f"| {p} | sectors | refused: narrower than the reach at R_i | | | | | |")
        else:
            cs = cut_for(x, p, 1, r_top)
            rows.append(("sectors", _count(x, ang_sorted, order, cs.radii, cs.edges, w)[:3]))
        best = None
        for rings in [d for d in range(2, p + 1) if p % d == 0 and d <= 64]:
            cr = cut_for(x, p, rings, r_top)
            counts = _count(x, ang_sorted, order, cr.radii, cr.edges, w)[:3]
            if best is None or counts[1].max() < best[1][1].max():
                best = (rings, counts)
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

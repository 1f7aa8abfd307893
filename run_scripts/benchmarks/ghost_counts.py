"""Ghosts per rank of a Couette scene cut for P = 16 ... 1024 ranks, counted from the disks'
positions, and the parallel efficiency the many-rank model of docs/scaling.md predicts from
them and from this machine's measured costs, for the scene and scaled up.

    python run_scripts/benchmarks/ghost_counts.py [SCENE] [--ranks 16 32 ... 1024]
        [--scale-to 1e7] [--latency 1e-6 2e-6 5e-6] [--bandwidth 1e10] [--csv FILE]
        [--figure FILE.png]

The positions are the scene's initial placement (pardem.input.placement), mapped radially onto the
final annulus at constant area fraction (r^2 - R_i^2 scaled), so the density is the sheared
cell's mean; the ghost width is pardem's (largest diameter + skin + GHOST_MARGIN_SKINS skins).
Two cuts, each with P domains of about equal counts, as pardem cuts them
(``parallel.choice.cut_for``):
- sectors;
- R rings of A = P / R sectors, R chosen among the divisors of P for the fewest ghosts (what
  ``pardem run --cut auto`` does, here without its test of each domain's width).
A ghost of domain d is a disk outside d within the ghost width of it (pardem's own distance,
``parallel.cut.edge_distance``); ``rank_counts.py`` checks these counts against real runs. A
cell scaled by k (radii x k, disks x k^2; ``--scale-to`` N disks) cut the same way has k times
the ghosts per domain: the band of width w along each edge grows with the edge.

The model (``step_time``), per step of the busiest rank:
``c N_own + c_g G + n_nbr (alpha + (24 + 40 G / n_nbr) / beta) + 2 log2(P) alpha
+ e (P - 1) alpha``: c and c_g measured on this machine (``machine_costs.py``, read from
results/scaling/machine_costs.csv), one refresh message per neighbour (3 header doubles, 5 per
ghost), an Allreduce of the step's maxima (recursive doubling) and, e times per step, an
exchange's all-to-all. The interconnect's latency alpha and bandwidth beta are assumptions
(``--latency``: the central value, then the others of the range printed); the efficiency is
c N / (P t).
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numba as nb
import numpy as np

from pardem.parallel.choice import cut_for
from pardem.parallel.cut import domain_geometry, edge_distance, owners

SCENES = Path(__file__).resolve().parents[1] / "scenes"
COSTS = Path(__file__).resolve().parents[2] / "results" / "scaling" / "machine_costs.csv"


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


def count(x, radii, edges, w):
    """Per domain of the cut (radii, edges) of the disks x [N,2]: owned disks, ghosts within
    ``w``, neighbour domains."""
    ang = np.arctan2(x[:, 1], x[:, 0])
    order = np.argsort(ang, kind="stable")
    return _count(x, ang[order], order, radii, edges, w)[:3]


def placement(scene_path: Path, r2_mean: float | None = None):
    """The scene's free disks where its placement puts them, mapped radially at constant area
    fraction (r^2 - R_i^2 scaled) onto the annulus from R_i to the final R_o, or so that their
    mean r^2 is ``r2_mean`` (a run's); and the ghost width. Returns ``(x [N,2], w)``."""
    from pardem.input.placement import initial_configuration
    from pardem.input.scene_file import load_scene
    from pardem.parallel import GHOST_MARGIN_SKINS

    scene = load_scene(scene_path)
    g = scene.geometry
    init = initial_configuration(scene)
    x = init.x[:init.n_free]
    r2, ri2 = np.sum(x * x, axis=1), g.inner_radius**2
    if r2_mean is None:  # the placement fills R_i..outer_start_radius at the final density
        scale = (g.outer_radius**2 - ri2) / (g.outer_start_radius**2 - ri2)
    else:
        scale = (r2_mean - ri2) / (r2.mean() - ri2)
    r2_new = ri2 + (r2 - ri2) * scale
    x = x * np.sqrt(r2_new / r2)[:, None]
    skin = scene.neighbors.skin or 0.1 * scene.min_free_diameter
    w = 2.0 * float(init.radius[:init.n_free].max()) + skin + GHOST_MARGIN_SKINS * skin
    return x, w


def count_cut(x, p: int, rings: int, w: float):
    """``count`` for the cut of x into ``rings`` rings of p / rings domains of equal counts."""
    r_top = float(np.sqrt(np.sum(x * x, axis=1).max())) * (1.0 + 1e-9)
    c = cut_for(x, p, rings, r_top)
    return count(x, c.radii, c.edges, w)


def costs(path: Path = COSTS) -> dict[str, float]:
    """The measured medians of results/scaling/machine_costs.csv by quantity."""
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines() if not ln.startswith("#")]
    return {r["quantity"]: float(r["median"]) for r in csv.DictReader(lines)}


def step_time(own, ghosts, nbr, p, cost, alpha, beta):
    """Modelled seconds per step of a rank with ``own`` disks, ``ghosts`` and ``nbr``
    neighbour ranks among ``p`` (the module docstring's model; ``cost``: ``costs()``)."""
    t = 1e-9 * (cost["c_ns"] * own + cost["c_g_ns"] * ghosts)
    t += nbr * alpha + 8.0 * (3 * nbr + 5 * ghosts) / beta
    if p > 3:  # else the refresh's headers carry the maxima
        t += 2.0 * math.log2(p) * alpha
    return t + 1e-3 * cost["exchanges_per_1000_steps"] * (p - 1) * alpha


def predict(x, w, p: int, cuts_of) -> list[tuple[str, int, np.ndarray, np.ndarray]]:
    """(cut, rings, ghosts, neighbours) per domain for sectors and the best rings x sectors."""
    out = []
    for rings in cuts_of(p):
        owned, ghosts, nbr = count_cut(x, p, rings, w)
        assert owned.sum() == x.shape[0]
        out.append((f"{rings} × {p // rings}", rings, ghosts, nbr))
    best = min(out[1:], key=lambda o: o[2].max())
    return [out[0], best]


def main() -> None:
    from pardem.input.scene_file import load_scene
    from pardem.parallel import GHOST_MARGIN_SKINS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", type=Path, default=SCENES / "couette_B_1M.toml")
    ap.add_argument("--ranks", type=int, nargs="+", default=[16, 32, 64, 128, 256, 512, 1024])
    ap.add_argument("--scale-to", type=float, nargs="*", default=[1e7])
    ap.add_argument("--latency", type=float, nargs="+", default=[2e-6, 1e-6, 5e-6],
                    help="s per message between nodes (assumed): the central value, then bounds")
    ap.add_argument("--bandwidth", type=float, default=1e10, help="B/s per link (assumed)")
    ap.add_argument("--csv", type=Path)
    ap.add_argument("--figure", type=Path)
    args = ap.parse_args()
    scene = load_scene(args.scene)
    g = scene.geometry
    x, w = placement(args.scene)
    skin = scene.neighbors.skin or 0.1 * scene.min_free_diameter
    reach = w - GHOST_MARGIN_SKINS * skin  # pardem refuses sectors narrower at R_i
    n = x.shape[0]
    cost = costs()
    print(f"{args.scene.name}: {n} free disks, R_i = {g.inner_radius} m, R_o = {g.outer_radius} m,"
          f" ghost width {1e3 * w:.2f} mm; {cost}")

    def cuts_of(p):
        return [1] + [d for d in range(2, p + 1) if p % d == 0 and d <= 64]

    rows, cells = [], [n] + [int(m) for m in args.scale_to]
    for p in args.ranks:
        row = {"ranks": p}
        for name, rings, ghosts, nbr in predict(x, w, p, cuts_of):
            kind = "sectors" if rings == 1 else "rings"
            row[f"{kind}_cut"] = name
            for m in cells:
                k = math.sqrt(m / n)  # ghosts grow with the edges, x k
                tag = f"{kind}_{m:.0e}".replace("+0", "").replace("+", "")
                if rings == 1 and 2 * math.pi * k * g.inner_radius / p < reach:
                    row.update({f"{tag}_{f}": "" for f in ("ghosts", "ghosts_per_owned",
                                                           "efficiency", "efficiency_range")})
                    continue
                g_max, nbr_max = k * ghosts.max(), int(nbr.max())
                eff = [cost["c_ns"] * 1e-9 * m / (p * step_time(
                    m / p, g_max, nbr_max, p, cost, a, args.bandwidth)) for a in args.latency]
                row[f"{tag}_ghosts"] = round(g_max)
                row[f"{tag}_ghosts_per_owned"] = f"{g_max * p / m:.2f}"
                row[f"{tag}_efficiency"] = f"{eff[0]:.2f}"
                row[f"{tag}_efficiency_range"] = f"{min(eff):.2f}–{max(eff):.2f}"
        for m in cells:
            row[f"owned_{m:.0e}".replace("+0", "").replace("+", "")] = round(m / p)
        rows.append(row)
        print(row, flush=True)
    if args.csv:
        write_csv(args, rows, cost, w)
    if args.figure:
        figure(args.figure, rows, cells, args.latency)


def write_csv(args, rows, cost, w) -> None:
    lat = ", ".join(f"{1e6 * a:g}" for a in args.latency)
    with args.csv.open("w", encoding="utf-8", newline="") as f:
        f.write("# Parallel efficiency at P ranks predicted from counted ghosts and this "
                "machine's measured costs, with an assumed interconnect.\n"
                "# script: run_scripts/benchmarks/ghost_counts.py\n"
                f"# command: python run_scripts/benchmarks/ghost_counts.py {args.scene.name} "
                f"--csv {args.csv.name}" + (f" --figure {args.figure.name}" if args.figure else "")
                + f" (ghost width {1e3 * w:.2f} mm; latency {lat} us, "
                f"bandwidth {args.bandwidth / 1e9:g} GB/s assumed; measured costs {cost})\n"
                "# units: owned_N = disks per rank of an N-disk cell; *_ghosts = ghosts of the "
                "busiest rank; *_efficiency = c N / (P t_step) at the first latency, *_range "
                "over the latencies\n")
        out = csv.DictWriter(f, list(rows[0]))
        out.writeheader()
        out.writerows(rows)


def figure(path: Path, rows, cells, latency) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for m, style in zip(cells, ("-", "--")):
        tag = f"{m:.0e}".replace("+0", "").replace("+", "")
        for kind, colour in (("sectors", "tab:red"), ("rings", "tab:blue")):
            kept = [r for r in rows if r[f"{kind}_{tag}_efficiency"]]
            ps = [r["ranks"] for r in kept]
            eff = [float(r[f"{kind}_{tag}_efficiency"]) for r in kept]
            lo, hi = zip(*[map(float, r[f"{kind}_{tag}_efficiency_range"].split("–"))
                           for r in kept])
            label = f"{m:,} disks, {'sectors' if kind == 'sectors' else 'rings × sectors'}"
            ax.plot(ps, eff, style, color=colour, marker="o", ms=3, label=label)
            ax.fill_between(ps, lo, hi, color=colour, alpha=0.12)
    ax.set_xscale("log", base=2)
    ax.set_xlabel("MPI ranks P (one core each)")
    ax.set_ylabel("parallel efficiency (model)")
    ax.set_ylim(0, 1.05)
    ax.set_title(f"bands: inter-node latency {1e6 * min(latency):g}–{1e6 * max(latency):g} µs",
                 fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()

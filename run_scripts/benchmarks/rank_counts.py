"""Counts of many ranks from real runs: owned disks, ghosts, neighbour ranks, messages and bytes
sent, listed pairs, imbalance, builds and exchanges, per rank and step, on P = 4 ... 64 ranks
oversubscribed on the cores at hand. Counts only: the runs' times say nothing (several ranks
share each core), so none is printed.

    python run_scripts/benchmarks/rank_counts.py SCENE [--restart CKPT] [--ranks 4 8 16 32]
        [--cuts sectors auto] [--steps 400] [--samples 8] [--csv FILE] [--append]

Each (P, cut) is a fresh ``nice -n 19 mpiexec -n P`` job (``PARDEM_HALO=messages``: ranks that
spin on a shared window while others hold the cores would stall), from the checkpoint or from
the scene's placement, running ``--steps`` steps and sampling every rank's counts ``--samples``
times (``Simulation.stats``: the counts between two exchanges). Two checks of the ghosts, from
positions, by code apart from the exchange's (pardem's distance to a domain, tested against
closed forms in tests/test_ghost_counts.py):
- ``same positions``: ``ghost_counts.count`` on the owned disks where the last exchange saw
  them, cut as that exchange cut them: must give each rank's ghosts exactly;
- ``placement law``: ``ghost_counts.py``'s prediction (the scene's placement mapped onto the
  annulus at the run's mean density, cut afresh): the law the many-rank model extrapolates.
One row per run is printed and, with ``--csv``, one per (cell, P, cut) written (``--append``:
added; ``requested``: the ``--cut`` values that gave that cut).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
DOUBLES_PER_GHOST = 5  # x, y, v_pred (2), w_pred: the refresh block's row (parallel/halo.py)
HEADER_DOUBLES = 3  # the block's header: bad-particle flag, displacement, squared speed

FIELDS = ["requested", "cell", "free_disks", "t_s", "ranks", "cut", "steps", "owned_mean",
          "owned_max", "owned_imbalance", "ghosts_mean", "ghosts_max", "ghosts_per_owned",
          "neighbours_mean", "neighbours_max", "messages_max", "kB_sent_mean", "kB_sent_max",
          "pairs_mean", "pairs_imbalance", "builds_per_1000", "exchanges", "ghosts_same_positions_dev",
          "predicted_ghosts_mean", "predicted_ghosts_max", "measured_over_predicted_mean",
          "measured_over_predicted_max", "rss_MB_max"]


def worker(scene_path: str, restart: str | None, cut: str, steps: int, samples: int) -> None:
    """One run under mpiexec: prints a JSON line on rank 0."""
    from mpi4py import MPI

    import bench
    from pardem.simulation import Simulation

    comm = MPI.COMM_WORLD
    sim = Simulation(bench.scene_of(Path(scene_path), False), restart=restart, comm=comm,
                     cut=cut)
    d = sim.decomp
    builds, exchanges = sim.n_rebuilds, d.n_exchanges
    rows = []
    for k in range(samples):
        sim.advance_steps(steps // samples)
        rows.append(sim.stats())
    last = rows[-1]
    # where the last exchange saw this rank's owned disks, and the cut it used
    x_owned = d.x_exchanged[:last["owned"]]
    mine = {key: float(np.mean([r[key] for r in rows]))
            for key in ("owned", "ghosts", "pairs", "neighbours", "sent", "allreduce")}
    mine["ghosts_last"] = last["ghosts"]
    mine["rss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB on Linux
    ranks = comm.gather(mine, root=0)
    xs = comm.gather(x_owned, root=0)
    if comm.rank == 0:
        import ghost_counts

        x = np.concatenate(xs)
        owned, ghosts, _ = ghost_counts.count(x, d.cut.radii, d.cut.edges, d.ghost_width)
        print(json.dumps({
            "ranks": ranks, "t": sim.step * sim.dt, "n_free": sim.n_free,
            "rings": d.cut.rings, "per_ring": d.cut.count // d.cut.rings,
            "builds": sim.n_rebuilds - builds, "exchanges": d.n_exchanges - exchanges,
            "recount_owned": owned.tolist(), "recount_ghosts": ghosts.tolist(),
            "ghost_width": d.ghost_width, "r2_mean": float(np.mean(np.sum(x * x, axis=1)))}))


def run_one(scene: Path, restart: Path | None, p: int, cut: str, steps: int,
            samples: int) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1",
               PARDEM_HALO="messages")
    mpiexec = Path(sys.executable).parent / "mpiexec"
    cmd = ["nice", "-n", "19", str(mpiexec), "-n", str(p), sys.executable, "-m", "mpi4py",
           str(Path(__file__).resolve()), str(scene), "--worker", "--cuts", cut,
           "--steps", str(steps), "--samples", str(samples)]
    if restart is not None:
        cmd += ["--restart", str(restart)]
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=3600)
    if out.returncode:
        raise SystemExit(f"rank_counts.py: {p} ranks, --cut {cut} failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def row_of(scene: Path, res: dict, p: int, steps: int, predicted) -> dict:
    ranks = res["ranks"]
    col = {k: np.array([r[k] for r in ranks]) for k in ranks[0]}
    kb = 8e-3 * (HEADER_DOUBLES * col["neighbours"] + DOUBLES_PER_GHOST * col["sent"])
    dev = np.abs(np.array(res["recount_ghosts"]) - col["ghosts_last"]).max() / max(
        col["ghosts_last"].max(), 1)
    g_mean, g_max = col["ghosts"].mean(), col["ghosts"].max()
    return {
        "cell": scene.stem, "free_disks": res["n_free"], "t_s": f"{res['t']:.3f}", "ranks": p,
        "cut": f"{res['rings']} × {res['per_ring']}", "steps": steps,
        "owned_mean": round(col["owned"].mean()), "owned_max": round(col["owned"].max()),
        "owned_imbalance": f"{col['owned'].max() / col['owned'].mean():.3f}",
        "ghosts_mean": round(g_mean), "ghosts_max": round(g_max),
        "ghosts_per_owned": f"{g_mean / col['owned'].mean():.3f}",
        "neighbours_mean": f"{col['neighbours'].mean():.1f}",
        "neighbours_max": round(col["neighbours"].max()),
        "messages_max": round((col["neighbours"] + col["allreduce"]).max()),
        "kB_sent_mean": f"{kb.mean():.2f}", "kB_sent_max": f"{kb.max():.2f}",
        "pairs_mean": round(col["pairs"].mean()),
        "pairs_imbalance": f"{col['pairs'].max() / col['pairs'].mean():.3f}",
        "builds_per_1000": f"{1000 * res['builds'] / steps:.1f}", "exchanges": res["exchanges"],
        "ghosts_same_positions_dev": f"{dev:.4f}",
        "predicted_ghosts_mean": round(predicted[1].mean()),
        "predicted_ghosts_max": int(predicted[1].max()),
        "measured_over_predicted_mean": f"{g_mean / predicted[1].mean():.3f}",
        "measured_over_predicted_max": f"{g_max / predicted[1].max():.3f}",
        "rss_MB_max": round(col["rss_MB"].max())}


def merged(rows: list[dict]) -> list[dict]:
    """The rows, one per (cell, P, cut): ``auto`` that chose sectors ran the same cut."""
    out: dict = {}
    for row in rows:
        key = (row["cell"], row["ranks"], row["cut"])
        if key in out:
            out[key]["requested"] = f"{out[key]['requested']}, {row['requested']}"
        else:
            out[key] = row
    return list(out.values())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--restart", type=Path)
    ap.add_argument("--ranks", type=int, nargs="+", default=[4, 8, 16, 32])
    ap.add_argument("--cuts", nargs="+", default=["sectors", "auto"])
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--csv", type=Path)
    ap.add_argument("--append", action="store_true")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker(str(args.scene), args.restart and str(args.restart), args.cuts[0],
                      args.steps, args.samples)
    import ghost_counts

    rows = []
    for p in args.ranks:
        for cut in args.cuts:
            res = run_one(args.scene, args.restart, p, cut, args.steps, args.samples)
            # the placement law at the run's density: the annulus whose mean r^2 is the run's
            x_law, w = ghost_counts.placement(args.scene, r2_mean=res["r2_mean"])
            predicted = ghost_counts.count_cut(x_law, p, res["rings"], w)
            rows.append({"requested": cut, **row_of(args.scene, res, p, args.steps, predicted)})
            print(json.dumps(rows[-1]), flush=True)
    if args.csv:
        new = not (args.append and args.csv.exists())
        with args.csv.open("w" if new else "a", encoding="utf-8", newline="") as f:
            if new:
                f.write("# Counts per rank and step of real runs on P ranks (oversubscribed: "
                        "counts only), against the geometric prediction.\n"
                        "# script: run_scripts/benchmarks/rank_counts.py\n")
            f.write(f"# command: python run_scripts/benchmarks/rank_counts.py "
                    f"{' '.join(sys.argv[1:])}\n")
            out = csv.DictWriter(f, FIELDS)
            if new:
                out.writeheader()
            out.writerows(merged(rows))


if __name__ == "__main__":
    main()

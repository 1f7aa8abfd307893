"""Reproduce the paper: simulations A, B, C for 239 s on MPI ranks, then figures 1.2-1.9 and the
comparison table.

    python run_scripts/paper/reproduce_paper.py [--ranks 2] [--runs runs/paper]
                                                [--results results/paper] [--only A B C]
                                                [--skip-runs]

Each simulation is ``mpiexec -n RANKS pardem run run_scripts/scenes/couette_X.toml --out
RUNS/X`` (the scenes average over 180-239 s in situ and write rings.h5). The wall time of every
run, the command and the machine are written to RUNS/runs.json before the figures are made, so
``--skip-runs`` can redo the figures and the table from finished runs. Figures, table, resolved
scene files and run information go to RESULTS (default results/paper, committed); the raw run
folders (about 0.3 GB each) stay in RUNS, outside git.

``--from-study DIR`` makes the figures and table from the calibration study's runs in DIR
(``run_scripts/studies/calibration_study.py --runs DIR``) instead of running: seeds 1-3 of A,
B and C with the calibrated N_in, which are the shipped scenes (those seeds) under another
name; every number is the seed mean with its standard error; the command and wall time of
each come from its table in docs/roughness/runs/.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENES = HERE.parent / "scenes"
STUDIES = HERE.parent / "studies"


def machine() -> dict:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "system": platform.platform()}


def run_one(name: str, ranks: int, out: Path) -> dict:
    mpiexec = Path(sys.executable).parent / "mpiexec"
    pardem = Path(sys.executable).parent / "pardem"
    cmd = [str(mpiexec), "-n", str(ranks), str(pardem), "run",
           str(SCENES / f"couette_{name}.toml"), "--out", str(out), "--overwrite"]
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    print(f"[{name}] {' '.join(cmd)}", flush=True)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, env=env)
    wall = time.perf_counter() - t0
    print(f"[{name}] done in {wall / 60:.1f} min", flush=True)
    return {"command": " ".join(["mpiexec", "-n", str(ranks), "pardem", "run",
                                 f"run_scripts/scenes/couette_{name}.toml", "--out", str(out),
                                 "--overwrite"]),
            "wall_s": wall, "ranks": ranks}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--runs", type=Path, default=Path("runs/paper"))
    ap.add_argument("--results", type=Path, default=Path("results/paper"))
    ap.add_argument("--only", nargs="+", default=["A", "B", "C"], choices=["A", "B", "C"])
    ap.add_argument("--skip-runs", action="store_true", help="figures and table only")
    ap.add_argument("--from-study", type=Path, metavar="DIR",
                    help="figures and table from the calibration study's runs in DIR")
    args = ap.parse_args(argv)
    if args.from_study:
        return from_study(args.from_study, args.results)
    args.runs.mkdir(parents=True, exist_ok=True)
    info_path = args.runs / "runs.json"
    info = json.loads(info_path.read_text()) if info_path.exists() else {}
    if not args.skip_runs:
        for name in args.only:
            info[name] = run_one(name, args.ranks, args.runs / name)
            info["machine"] = machine()
            tmp = info_path.with_suffix(".tmp")
            tmp.write_text(json.dumps(info, indent=2))
            os.replace(tmp, info_path)
    sys.path.insert(0, str(HERE))
    import paper_figures  # noqa: E402 (after the runs: a figure bug never costs a rerun)

    return paper_figures.main([str(args.runs / n) for n in ("A", "B", "C")
                               if (args.runs / n / "rings.h5").exists()]
                              + ["--results", str(args.results), "--runs-info", str(info_path)])


def from_study(runs: Path, results: Path) -> int:
    sys.path[:0] = [str(HERE), str(STUDIES)]
    import calibration_study as cal  # noqa: E402
    import paper_figures  # noqa: E402
    import study_runs as rs  # noqa: E402

    n = cal.next_value(cal.points())[1]
    if n is None:
        raise SystemExit("--from-study: the calibration (calibration_study.py) chose no N_in yet")
    names = {x: [f"{cal.cal_name(n, x)}-s{s}" for s in rs.SEEDS] for x in ("A", "B", "C")}
    missing = [m for group in names.values() for m in group
               if not (runs / m / "rings.h5").exists() or not (rs.TABLES / f"{m}.json").exists()]
    if missing:
        raise SystemExit(f"--from-study {runs}: no finished run {', '.join(missing)}")
    info = {}
    for x, group in names.items():
        rows = [json.loads((rs.TABLES / f"{m}.json").read_text()) for m in group]
        info[x] = {"command": f"{rows[0]['command']} (calibration study, N_in = {n}: "
                              f"couette_{x}.toml with seeds {', '.join(map(str, rs.SEEDS))}; "
                              f"{rows[0]['ranks']} rank each, mean wall time)",
                   "wall_s": sum(r["wall_s"] for r in rows) / len(rows),
                   "ranks": rows[0]["ranks"]}
    info["machine"] = machine()
    with tempfile.TemporaryDirectory() as tmp:
        info_path = Path(tmp) / "runs.json"  # comparison.json keeps it
        info_path.write_text(json.dumps(info, indent=2))
        return paper_figures.main([str(runs / m) for group in names.values() for m in group]
                                  + ["--results", str(results), "--runs-info", str(info_path),
                                     "--names"] + [x for x, g in names.items() for _ in g])


if __name__ == "__main__":
    sys.exit(main())

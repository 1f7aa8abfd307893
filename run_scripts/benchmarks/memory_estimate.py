"""Benchmark: ``pardem check``'s memory estimate against the measured peak of the same run.

    python run_scripts/benchmarks/memory_estimate.py [--ranks 2] [--cases quick 30k rings]
                                                     [--out results/robustness/memory.json]

Each case is a shipped scene, shortened (``CASES``), run with ``mpiexec -n RANKS pardem run``
twice: the first run fills numba's cache (compiling takes memory of its own, which a later run
does not pay), the second is measured. The run logs its busiest rank's peak resident memory
(``ru_maxrss``, imports and kernels included) beside the estimate (``core/memory.py``,
``needed_bytes``); this prints both and their ratio, writes them to ``--out`` as JSON and the
table of docs/running.md (between ``<!-- table: memory -->`` and ``<!-- end -->``) from it.
``--table``: only the table, from the committed JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "run_scripts" / "scenes"

CASES = {
    # the README's quick scene as shipped: set-up, 6 s of steps, 41 samples of 161 rings
    "quick": ("couette_quick.toml", {}),
    # 30,000 disks: set-up and the first 0.2 s of the compression (no averaging yet)
    "30k": ("couette_B_30k.toml", {"time": {"end": 0.2}, "averaging": None}),
    # the quick cell averaged in 99,993 rings (11 samples): the averaging's memory dominates
    "rings": ("couette_quick.toml", {"time": {"end": 2.5},
                                     "averaging": {"start": 2.0, "end": 2.5,
                                                   "ring_width": 1.4901e-6}}),
}


def case_scene(name: str, folder: Path) -> Path:
    """The case's scene file, written into ``folder``."""
    from pardem.input.scene_file import load_scene, write_scene
    from pardem.input.schema import scene_from_dict

    file, changes = CASES[name]
    d = load_scene(SCENES / file).to_dict()
    for table, keys in changes.items():
        if keys is None:
            d.pop(table, None)
        else:
            d.setdefault(table, {}).update(keys)
    path = folder / f"{name}.toml"
    write_scene(scene_from_dict(d), path)
    return path


def measure(path: Path, ranks: int, out: Path) -> tuple[float, float]:
    """(peak, estimate) in MiB from the log of a run of ``path``."""
    cmd = ["mpiexec", "-n", str(ranks), sys.executable, "-m", "pardem.cli", "run", str(path),
           "--out", str(out), "--overwrite", "--quiet"]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env={**os.environ, "PYTHONPATH": str(ROOT)})
    text = (out / "log.txt").read_text()
    found = re.findall(r"memory: peak (\S+) (\w+) on the busiest rank \(pardem check's "
                       r"estimate: (\S+) (\w+)\)", text)
    if not found:
        raise SystemExit(f"{out}/log.txt: no memory line")
    peak, unit_p, est, unit_e = found[-1]
    scale = {"MiB": 1.0, "GiB": 1024.0, "TiB": 1024.0**2}
    return float(peak) * scale[unit_p], float(est) * scale[unit_e]


RESULTS = ROOT / "results" / "robustness" / "memory.json"
PAGE = ROOT / "docs" / "running.md"
MARK = re.compile(r"(<!-- table: memory -->\n)(.*?)(<!-- end -->)", re.S)
WHAT = {"quick": "the quick scene (2,939 disks, 6 s, 41 samples of 161 rings)",
        "30k": "30,000 disks, set-up and 0.2 s of steps",
        "rings": "the quick cell in 99,993 rings (11 samples)"}


def table(rows: list[dict]) -> str:
    """The page's table of ``rows`` (the JSON's)."""
    lines = ["| run | ranks | measured peak (MiB) | estimate (MiB) | estimate / peak |",
             "|---|---|---|---|---|"]
    lines += [f"| {WHAT[r['case']]} | {r['ranks']} | {r['peak_mib']:.0f} | "
              f"{r['estimate_mib']:.0f} | {r['estimate_over_peak']:.2f} |" for r in rows]
    return "\n".join(lines) + "\n"


def write_table(rows: list[dict]) -> None:
    text = PAGE.read_text()
    PAGE.write_text(MARK.sub(lambda m: m.group(1) + table(rows) + m.group(3), text))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--out", type=Path, default=RESULTS)
    ap.add_argument("--table", action="store_true")
    args = ap.parse_args()
    if args.table:
        return write_table(json.loads(args.out.read_text()))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.cases:
            path = case_scene(name, Path(tmp))
            measure(path, args.ranks, Path(tmp) / f"{name}-warm")  # fills the kernel cache
            peak, estimate = measure(path, args.ranks, Path(tmp) / name)
            rows.append({"case": name, "scene": CASES[name][0], "ranks": args.ranks,
                         "peak_mib": peak, "estimate_mib": estimate,
                         "estimate_over_peak": estimate / peak})
            print(f"{name:6s} {args.ranks} ranks: peak {peak:8.1f} MiB, estimate "
                  f"{estimate:8.1f} MiB, estimate / peak = {estimate / peak:.2f}", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(rows, indent=1) + "\n")
    write_table(rows)


if __name__ == "__main__":
    main()

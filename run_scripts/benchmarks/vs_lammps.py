"""Benchmark: pardem against LAMMPS on one core, the same Couette cell side by side.

    python run_scripts/benchmarks/vs_lammps.py [--repeats 5] [--steps 10000] [--at 2.5]
                                               [--scene FILE] [--checkpoint FILE]
                                               [--lmp lmp] [--bfric]

Each round runs LAMMPS's deck of the paper's cell B (``../shared/reference/lammps``: Debian's
``lmp``, GRANULAR's Hooke law with history, the same k_n, gamma_n, k_t, mu, dt and skin, 2939
flow disks between glued-disk walls; its README says how to install it) and then pardem's
couette_B (``bench.py``'s worker, one rank, NUMBA_NUM_THREADS=1) from its state at ``--at``
seconds (``--checkpoint``: made once if missing; 2.5 s, just after the compression, by default;
steady shear is B's state at 239 s, the checkpoint a finished ``pardem run`` of B leaves, with
``--scene`` its scene.toml). LAMMPS times ``--steps`` steps after 200
warm-up steps (its second ``Loop time``); pardem the same number after two neighbour builds.
Each round also runs ``vs_bare_loop.py``'s bare numba loop of the same law on pardem's fixed
pair list (the yardstick of a plain time step on this machine; its docstring says what it
leaves out). Prints each run's flow-particle-steps/s, the medians, and per round pardem over
LAMMPS, pardem over the bare loop and the bare loop over LAMMPS, with medians and spreads. LAMMPS runs without bottom friction (``--bfric``: with it, as atom-style
variables that cost LAMMPS about 80 %); pardem always has it. What else differs: LAMMPS's
packing is its own settled one, not the ring's compression (see the deck's README).

About 40 s per round on this machine (LAMMPS ~4 s per 10,000 steps, pardem and the bare loop
~1 s each plus start-up).
"""

from __future__ import annotations

import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from bench import ROOT, _worker_run, compress
from vs_bare_loop import bare_run, one_core_parser

DECK = ROOT.parent / "shared" / "reference" / "lammps"
N_FLOW = 2939  # the deck's flow disks (types 1 and 2), as couette_B's


def lammps_rate(lmp: str, steps: int, bfric: bool, log: Path) -> float:
    """Flow-particle-steps/s of one LAMMPS run of the deck on one core."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    subprocess.run([lmp, "-in", "in.couette", "-var", "datain", "data/couette_settled.data",
                    "-var", "nsteps", str(steps), "-var", "warm", "200",
                    *(["-var", "bfric", "1"] if bfric else []), "-screen", "none",
                    "-log", str(log)], cwd=DECK, env=env, check=True, timeout=3600)
    loops = re.findall(r"^Loop time of ([0-9.eE+-]+) on 1 procs", log.read_text(), re.M)
    if len(loops) != 2:
        raise RuntimeError(f"{log}: expected two 'Loop time ... on 1 procs' lines, got "
                           f"{len(loops)} (did LAMMPS run on one process?)")
    return N_FLOW * steps / float(loops[1])


def main() -> None:
    ap = one_core_parser(__doc__)
    ap.add_argument("--lmp", default="lmp", help="the LAMMPS binary")
    ap.add_argument("--bfric", action="store_true", help="LAMMPS with bottom friction too")
    args = ap.parse_args()
    if not (DECK / "in.couette").exists():
        sys.exit(f"vs_lammps.py: the LAMMPS deck is not at {DECK}")
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    mpiexec = Path(sys.executable).parent / "mpiexec"
    with tempfile.TemporaryDirectory() as tmp:
        ckpt = args.checkpoint or Path(tmp) / "compressed.h5"
        if not ckpt.exists():
            compress(ckpt, args.scene, args.at)
        ours, theirs, bare = [], [], []
        for k in range(args.repeats):
            theirs.append(lammps_rate(args.lmp, args.steps, args.bfric, Path(tmp) / "log.lammps"))
            bare.append(bare_run(ckpt, args.steps, args.scene.resolve(), env)["rate"])
            res = _worker_run(mpiexec, ROOT, ckpt, args.steps, False, 1, env,
                              args.scene.resolve())
            ours.append(res["n_free"] * args.steps / res["wall"])
            print(f"round {k + 1}: LAMMPS {theirs[-1] / 1e6:.2f} M, bare loop {bare[-1] / 1e6:.2f} "
                  f"M, pardem {ours[-1] / 1e6:.2f} M flow-particle-steps/s: pardem / LAMMPS "
                  f"{ours[-1] / theirs[-1]:.2f}, pardem / bare {ours[-1] / bare[-1]:.3f}",
                  flush=True)
    print(f"one core, {args.steps} steps, {args.repeats} rounds (medians, range):")
    lammps = f"LAMMPS{' with bottom friction' if args.bfric else ''}"
    for name, r in (("pardem", ours), (lammps, theirs), ("bare loop", bare)):
        print(f"  {name}: {statistics.median(r) / 1e6:.2f} M ({min(r) / 1e6:.2f}-"
              f"{max(r) / 1e6:.2f})")
    for name, a, b in (("pardem / LAMMPS", ours, theirs), ("pardem / bare loop", ours, bare),
                       ("bare loop / LAMMPS", bare, theirs)):
        per_round = [x / y for x, y in zip(a, b)]
        print(f"  {name}: {statistics.median(a) / statistics.median(b):.3f} (ratio of the "
              f"medians), per round median {statistics.median(per_round):.3f}, spread "
              f"{min(per_round):.3f}-{max(per_round):.3f}")


if __name__ == "__main__":
    main()

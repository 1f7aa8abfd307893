"""Benchmark: pardem against LAMMPS, the same Couette cell side by side, on one core (and, with
``--two-ranks``, both codes' speed-up on two).

    python run_scripts/benchmarks/vs_lammps.py [--repeats 5] [--steps 10000] [--at 2.5]
                                               [--scene FILE] [--checkpoint FILE]
                                               [--lmp lmp] [--bfric] [--two-ranks]

Each round runs LAMMPS's deck of the paper's cell B (``../shared/reference/lammps``: Debian's
``lmp``, GRANULAR's Hooke law with history, the same k_n, gamma_n, k_t, mu, dt and skin, 2939
flow disks between glued-disk walls; its README says how to install it), then
``vs_bare_loop.py``'s bare numba loop of the same law on pardem's fixed pair list (the
yardstick of a plain time step on this machine; its docstring says what it leaves out), then
pardem's couette_B (``bench.py``'s worker, one rank, NUMBA_NUM_THREADS=1), both from pardem's
state at ``--at`` seconds (``--checkpoint``: made once if missing; 2.5 s, just after the
compression, by default; steady shear is B's state at 239 s, the checkpoint a finished ``pardem
run`` of B leaves, with ``--scene`` its scene.toml). LAMMPS times ``--steps`` steps after 200
warm-up steps (its second ``Loop time``); pardem the same number after two neighbour builds.
Prints each run's flow-particle-steps/s, the medians, and per round pardem over LAMMPS, pardem
over the bare loop and the bare loop over LAMMPS, with medians and spreads.

``--two-ranks``: instead, each round runs LAMMPS (under Open MPI's ``mpirun``, one core per
rank) and pardem on 1 and on 2 ranks, and prints both codes' 2-rank speed-ups side by side.

LAMMPS runs without bottom friction (``--bfric``: with it, as atom-style variables that cost
LAMMPS about 80 %); pardem always has it. What else differs: LAMMPS's packing is its own settled
one, not the ring's compression (see the deck's README). About 40 s per round on this machine
(LAMMPS ~4 s per 10,000 steps, pardem and the bare loop ~1 s each plus start-up).
"""

from __future__ import annotations

import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from bench import ROOT, _worker_run, compress
from vs_bare_loop import bare_run, one_core_parser, summary

DECK = ROOT.parent / "shared" / "reference" / "lammps"
N_FLOW = 2939  # the deck's flow disks (types 1 and 2), as couette_B's


def lammps_rate(lmp: str, steps: int, bfric: bool, log: Path, ranks: int = 1) -> float:
    """Flow-particle-steps/s of one LAMMPS run of the deck on ``ranks`` cores (more than one:
    under Debian's Open MPI ``mpirun``, one core per rank)."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    # the mpirun beside lmp (Debian's Open MPI, which lmp is built against), not the venv's
    # MPICH one, which would start two one-process LAMMPS runs
    mpirun = Path(shutil.which(lmp) or lmp).resolve().parent / "mpirun"
    launch = [str(mpirun), "-np", str(ranks), "--bind-to", "core"] if ranks > 1 else []
    subprocess.run([*launch, lmp, "-in", "in.couette", "-var", "datain",
                    "data/couette_settled.data", "-var", "nsteps", str(steps), "-var", "warm",
                    "200", *(["-var", "bfric", "1"] if bfric else []), "-screen", "none",
                    "-log", str(log)], cwd=DECK, env=env, check=True, timeout=3600)
    loops = re.findall(rf"^Loop time of ([0-9.eE+-]+) on {ranks} procs", log.read_text(), re.M)
    if len(loops) != 2:
        raise RuntimeError(f"{log}: expected two 'Loop time ... on {ranks} procs' lines, got "
                           f"{len(loops)}")
    return N_FLOW * steps / float(loops[1])


def two_ranks(args, ckpt: Path, tmp: Path, mpiexec: Path, env: dict) -> None:
    """``--two-ranks``: each round LAMMPS on 1 and on 2 ranks, then pardem on 1 and on 2;
    prints both codes' 2-rank speed-ups per round, their medians and spreads."""
    rate: dict = {(c, p): [] for c in ("LAMMPS", "pardem") for p in (1, 2)}
    for k in range(args.repeats):
        for p in (1, 2):
            rate["LAMMPS", p].append(lammps_rate(args.lmp, args.steps, args.bfric,
                                                 tmp / "log.lammps", p))
        for p in (1, 2):
            res = _worker_run(mpiexec, ROOT, ckpt, args.steps, False, p, env,
                              args.scene.resolve())
            rate["pardem", p].append(res["n_free"] * args.steps / res["wall"])
        print(f"round {k + 1}: " + ", ".join(
            f"{c} {rate[c, 1][-1] / 1e6:.2f} M on 1 rank, {rate[c, 2][-1] / 1e6:.2f} M on 2: "
            f"{rate[c, 2][-1] / rate[c, 1][-1]:.2f}" for c in ("LAMMPS", "pardem")), flush=True)
    print(f"1 against 2 ranks, {args.steps} steps, {args.repeats} rounds:")
    for c in ("LAMMPS", "pardem"):
        per_round = [b / a for a, b in zip(rate[c, 1], rate[c, 2])]
        print(f"  {c}: {statistics.median(rate[c, 1]) / 1e6:.2f} M on 1 rank, "
              f"{statistics.median(rate[c, 2]) / 1e6:.2f} M on 2; speed-up per round median "
              f"{statistics.median(per_round):.2f}, spread {min(per_round):.2f}-"
              f"{max(per_round):.2f}")


def main() -> None:
    ap = one_core_parser(__doc__)
    ap.add_argument("--lmp", default="lmp", help="the LAMMPS binary")
    ap.add_argument("--bfric", action="store_true", help="LAMMPS with bottom friction too")
    ap.add_argument("--two-ranks", action="store_true",
                    help="both codes on 1 and on 2 ranks: their 2-rank speed-ups side by side")
    args = ap.parse_args()
    if not (DECK / "in.couette").exists():
        sys.exit(f"vs_lammps.py: the LAMMPS deck is not at {DECK}")
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    mpiexec = Path(sys.executable).parent / "mpiexec"
    with tempfile.TemporaryDirectory() as tmp:
        ckpt = args.checkpoint or Path(tmp) / "compressed.h5"
        if not ckpt.exists():
            compress(ckpt, args.scene, args.at)
        if args.two_ranks:
            two_ranks(args, ckpt, Path(tmp), mpiexec, env)
            return
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
    summary({"pardem": ours, lammps: theirs, "bare loop": bare},
            [("pardem", lammps), ("pardem", "bare loop"), ("bare loop", lammps)])

if __name__ == "__main__":
    main()

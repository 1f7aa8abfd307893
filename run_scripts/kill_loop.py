"""Kill loop: SIGKILL a run that writes a snapshot every step, at random moments, many times;
after every kill the folder must hold a readable series equal to an uninterrupted run's, and
the runs continued from its checkpoints must end in that run's state, bit for bit.

    python run_scripts/kill_loop.py --kills 500 [--ranks 2] [--work DIR] [--seed 0]

The scene is ``examples/small_dense.toml`` (410 disks, 160 wall disks: contacts and flat-ring
contacts in every snapshot), compressed once to 1 s without snapshots (the "prep" run). Every
run of the loop continues from there with a snapshot every step and a checkpoint every
``--checkpoint-every`` steps, to ``--steps`` steps past the prep:
1. the reference runs once, uninterrupted; its wall time T sets the kill window;
2. a run starts (``pardem run --restart`` from the folder's own checkpoint, or from the prep's
   while the folder has none) and its whole process group (mpiexec and every rank) gets
   SIGKILL at a uniformly random moment in [0, T];
3. the folder is checked: every snapshot file opens and equals the reference's file of the same
   index in every dataset and attribute (the owning rank aside); the indexes run contiguously
   from the prep's step; both XDMF indexes parse and name only existing files and datasets, of
   the stated shapes;
4. a run that is not killed (it reached its end) must have written the whole series and the
   reference's final checkpoint; the loop then starts over in an emptied folder.
Prints a line per problem and the counts (also as ``RESULT {json}``): kills; kills that struck
after the run had written snapshots; kills that left a partial file (``*.tmp``); completed runs;
corrupted folders (any check failing: must be 0).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "small_dense.toml"
PREP_END = 1.0  # s: past the compression, the disks touch


def kill_scene(path: Path, steps: int, checkpoint_every: int) -> float:
    """small_dense with a snapshot every step and a checkpoint every ``checkpoint_every``
    steps, ending ``steps`` steps after PREP_END; written to ``path``. Returns dt."""
    from pardem.scene import load_scene
    from pardem.timestep import resolve_dt

    dt = resolve_dt(load_scene(SCENE))
    end_step = int(round(PREP_END / dt)) + steps
    text = SCENE.read_text().split("[time]")[0].split("[averaging]")[0]
    path.write_text(text + f"[time]\nend = {end_step * dt!r}\n\n[output]\n"
                    f"snapshot_interval = {dt!r}\ncheckpoint_interval = {checkpoint_every * dt!r}\n")
    return dt


def command(ranks: int, scene: Path, out: Path, *options: str) -> list[str]:
    cli = ["-m", "pardem.cli", "run", str(scene), "--out", str(out), "--quiet", *options]
    if ranks == 1:
        return [sys.executable, *cli]
    return [str(Path(sys.executable).parent / "mpiexec"), "-n", str(ranks), sys.executable,
            "-m", "mpi4py", *cli]


def start(cmd: list[str]) -> subprocess.Popen:
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env=env, start_new_session=True)  # its own group: killpg reaches all


def snapshot_files(run: Path) -> dict[int, Path]:
    folder = run / "snapshots"
    if not folder.is_dir():
        return {}
    return {int(p.name[:-3]): p for p in folder.glob("[0-9]*.h5")}


def problems(run: Path, ref: dict[int, Path], first: int) -> list[str]:
    """What is wrong with the run folder's series, against the reference's files."""
    found = []
    files = snapshot_files(run)
    indexes = sorted(files)
    if indexes and indexes != list(range(first, indexes[-1] + 1)):
        found.append(f"indexes not contiguous from {first}: {indexes[:3]}...{indexes[-3:]}")
    for i in indexes:
        try:
            with h5py.File(files[i], "r") as a, h5py.File(ref[i], "r") as b:
                found += [f"{files[i].name}: {d}" for d in differences(a, b)]
        except Exception as e:  # noqa: BLE001 - any failure to read is what we count
            found.append(f"{files[i].name}: cannot be read ({type(e).__name__}: {e})")
    for kind in ("particles", "contacts"):
        index = run / f"{kind}.xdmf"
        if index.exists():
            try:
                found += xdmf_problems(index, run)
            except Exception as e:  # noqa: BLE001
                found.append(f"{index.name}: cannot be read ({type(e).__name__}: {e})")
    return found


def differences(a: h5py.File, b: h5py.File) -> list[str]:
    names, others = [], []
    a.visit(names.append)
    b.visit(others.append)
    if sorted(names) != sorted(others):
        return [f"holds {sorted(set(names) ^ set(others))} unlike the reference"]
    diff = [f"attribute {k} differs" for k in b.attrs if a.attrs.get(k) != b.attrs[k]]
    for name in names:
        if isinstance(b[name], h5py.Dataset) and name != "rank":
            if not np.array_equal(a[name][()], b[name][()]):
                diff.append(f"{name} differs")
    return diff


def xdmf_problems(index: Path, run: Path) -> list[str]:
    grids = ET.parse(index).getroot().find("Domain").find("Grid").findall("Grid")
    found = []
    for grid in grids:
        for item in grid.iter("DataItem"):
            name, path = item.text.split(":")
            if not (run / name).exists():
                found.append(f"{index.name} names {name}, which does not exist")
                continue
            with h5py.File(run / name, "r") as h5:
                shape = tuple(int(d) for d in item.get("Dimensions").split())
                if path not in h5 or h5[path].shape != shape:
                    found.append(f"{index.name} names {name}:{path} {shape}, not in the file")
    return found


def same_checkpoint(a: Path, b: Path) -> bool:
    with h5py.File(a, "r") as x, h5py.File(b, "r") as y:
        return (x.attrs["step"] == y.attrs["step"] and sorted(x) == sorted(y)
                and all(np.array_equal(x[k][()], y[k][()]) for k in y))


def kill_loop(kills: int, ranks: int, work: Path, seed: int = 0, steps: int = 200,
              checkpoint_every: int = 20, say=print) -> dict:
    """Run the loop (module docstring) in ``work``; returns the counts."""
    work.mkdir(parents=True, exist_ok=True)
    scene, prep, ref, run = (work / "kill.toml", work / "prep", work / "ref", work / "run")
    dt = kill_scene(scene, steps, checkpoint_every)
    first = int(round(PREP_END / dt))
    if not (prep / "checkpoint.h5").exists():
        say(f"prep: compressing to {PREP_END} s (no snapshots)")
        _finish(start(command(ranks, SCENE, prep, "--end", repr(PREP_END), "--overwrite")))
    t0 = time.perf_counter()
    _finish(start(command(ranks, scene, ref, "--restart", str(prep), "--overwrite")))
    window = time.perf_counter() - t0
    reference = snapshot_files(ref)
    assert sorted(reference) == list(range(first, first + steps + 1)), "reference series"
    say(f"reference: {steps} steps with a snapshot each in {window:.1f} s; {kills} kills in "
        f"[0, {window:.1f}] s on {ranks} rank(s)")
    rng = random.Random(seed)
    counts = {"kills": 0, "while_writing": 0, "partial_file": 0, "completed": 0,
              "corrupted": 0, "ranks": ranks}
    shutil.rmtree(run, ignore_errors=True)
    while counts["kills"] < kills:
        own = (run / "checkpoint.h5").exists()
        options = ["--restart", str(run)] if own else ["--restart", str(prep), "--overwrite"]
        launched = time.time()
        proc = start(command(ranks, scene, run, *options))
        try:
            code = proc.wait(timeout=rng.uniform(0.0, window))
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            code = None
        err = proc.stderr.read()
        proc.stderr.close()
        found = problems(run, reference, first)
        if code is None:
            counts["kills"] += 1
            files = snapshot_files(run).values()
            counts["while_writing"] += any(p.stat().st_mtime >= launched for p in files)
            counts["partial_file"] += any((run / "snapshots").glob("*.tmp"))
        elif code == 0:
            counts["completed"] += 1
            if sorted(snapshot_files(run)) != sorted(reference):
                found.append("a completed run lacks snapshots")
            if not same_checkpoint(run / "checkpoint.h5", ref / "checkpoint.h5"):
                found.append("a completed run ends in another state than the reference")
            shutil.rmtree(run)
        else:
            found.append(f"the run exited {code}: {err.strip()[-300:]}")
        if found:
            counts["corrupted"] += 1
            say(f"kill {counts['kills']}: " + "; ".join(found[:5]))
            shutil.rmtree(run, ignore_errors=True)  # start over: one problem counted once
        if counts["kills"] % 50 == 0 and code is None:
            say(f"{counts}")
    return counts


def _finish(proc: subprocess.Popen) -> None:
    _, err = proc.communicate()
    if proc.returncode != 0:
        raise SystemExit(f"kill_loop: a run failed ({proc.returncode}):\n{err}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kills", type=int, default=500)
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--steps", type=int, default=200, help="steps per run past the prep")
    ap.add_argument("--checkpoint-every", type=int, default=20, help="steps")
    ap.add_argument("--work", help="folder for the runs (default: a temporary one)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        counts = kill_loop(args.kills, args.ranks, Path(args.work or tmp), args.seed,
                           args.steps, args.checkpoint_every)
    print("kills  while writing  partial file  completed runs  corrupted")
    print(f"{counts['kills']:5d}  {counts['while_writing']:13d}  {counts['partial_file']:12d}  "
          f"{counts['completed']:14d}  {counts['corrupted']:9d}")
    print("RESULT " + json.dumps(counts))


if __name__ == "__main__":
    main()

"""Kill loop: SIGKILL a run that writes a snapshot every step, at random moments, many times;
after every kill the folder must hold a readable series equal to an uninterrupted run's, and
the runs continued from its checkpoints must end in that run's state, bit for bit. With
``--signal INT`` or ``TERM`` it sends that signal instead, to mpiexec once or to one rank one
to three times a few ms apart (a second signal makes MPICH's mpiexec kill the job: the KILL
case): every such stop must end within 30 s (else: a hang), with exit
status 128 + the signal's number, no traceback, and a final checkpoint of the stopped state.

    python run_scripts/tools/kill_loop.py --kills 500 [--ranks 2] [--signal KILL] [--work DIR]

The scene is ``examples/small_dense.toml`` (410 disks, 160 wall disks: contacts and flat-ring
contacts in every snapshot), compressed once to 1 s without snapshots (the "prep" run). Every
run of the loop continues from there with a snapshot every step and a checkpoint every
``--checkpoint-every`` steps, to ``--steps`` steps past the prep:
1. the reference runs once, uninterrupted; its wall time T sets the kill window;
2. a run starts (``pardem run --restart`` from the folder's own checkpoint, or from the prep's
   while the folder has none) and mpiexec and every rank get SIGKILL at a uniformly random
   moment in [0, T]; a signal (INT, TERM) is sent at a random moment after the run has written
   its first snapshot (before, the run has not installed its handlers: Python's defaults
   apply), to the launcher or to one rank, chosen at random;
3. the folder is checked: every snapshot file opens and equals the reference's file of the same
   index in every dataset and attribute (the owning rank aside); the indexes run contiguously
   from the prep's step; both XDMF indexes parse and name only existing files and datasets, of
   the stated shapes, and particles.xdmf names the series from its start without a hole (the
   newest files may be missing from it: a kill between a file's rename and the index's
   rewrite, or during a restart's deletions). A file found equal is read again only if its
   inode, modification time or size changed (a completed file is never written again: that is
   what is tested);
4. a run that is not killed (it reached its end) must have written the whole series, indexed,
   and the reference's final checkpoint; the loop then starts over in an emptied folder.
Prints a line per problem and the counts (also as ``RESULT {json}``): kills (or signal stops);
those that struck after the run had written snapshots; those that left a partial file
(``*.tmp``); completed runs; hung runs and unclean stops (signals only); corrupted folders (any
check failing). All but the first four must be 0.
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

from pardem.output import xdmf

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "examples" / "small_dense.toml"
PREP_END = 1.0  # s: past the compression, the disks touch


def kill_scene(path: Path, steps: int, checkpoint_every: int) -> float:
    """small_dense with a snapshot every step and a checkpoint every ``checkpoint_every``
    steps, ending ``steps`` steps after PREP_END; written to ``path``. Returns dt."""
    from pardem.input.scene_file import load_scene
    from pardem.core.timestep import resolve_dt

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
                            env=env, start_new_session=True)  # mpiexec's group; see kill_all


def snapshot_files(run: Path) -> dict[int, Path]:
    return {i: run / xdmf.FOLDER / xdmf.file_name(i) for i in xdmf.snapshot_indexes(run)}


def contents(path: Path) -> tuple[dict, dict]:
    """(root attributes, {dataset path: array, group path: None}) of a snapshot file."""
    with h5py.File(path, "r") as h5:
        names = []
        h5.visit(names.append)
        return (dict(h5.attrs), {n: h5[n][()] if isinstance(h5[n], h5py.Dataset) else None
                                 for n in names})


def problems(run: Path, ref: dict[int, tuple], first: int, verified: dict) -> list[str]:
    """What is wrong with the run folder's series, against the reference's contents.
    ``verified``: files found equal before, by (inode, mtime, size); a completed file is never
    written again, so one that kept these needs no second reading."""
    found = []
    files = snapshot_files(run)
    indexes = sorted(files)
    if indexes and indexes != list(range(first, indexes[-1] + 1)):
        found.append(f"indexes not contiguous from {first}: {indexes[:3]}...{indexes[-3:]}")
    for i in indexes:
        s = files[i].stat()
        stamp = (s.st_ino, s.st_mtime_ns, s.st_size)
        if verified.get(files[i]) == stamp:
            continue
        try:
            attrs, data = contents(files[i])
        except Exception as e:  # noqa: BLE001 - any failure to read is what we count
            found.append(f"{files[i].name}: cannot be read ({type(e).__name__}: {e})")
            continue
        diff = differences(attrs, data, *ref[i])
        found += [f"{files[i].name}: {d}" for d in diff]
        if not diff:
            verified[files[i]] = stamp
    known = {f"snapshots/{files[i].name}": {n: getattr(a, "shape", None)
                                            for n, a in ref[i][1].items()}
             for i in indexes if files[i] in verified}
    # the particle index must list a prefix of the series, without holes: the newest files
    # may be missing from it (a kill between a file's rename and the index's rewrite, or while a
    # restart deletes the files past its checkpoint after shortening the index); contacts.xdmf
    # leaves out snapshots without contacts
    series = [f"snapshots/{files[i].name}" for i in indexes]
    for kind in ("particles", "contacts"):
        index = run / f"{kind}.xdmf"
        if index.exists():
            try:
                found += xdmf_problems(index, run, known,
                                       series if kind == "particles" else [])
            except Exception as e:  # noqa: BLE001
                found.append(f"{index.name}: cannot be read ({type(e).__name__}: {e})")
    return found


def differences(attrs: dict, data: dict, ref_attrs: dict, ref_data: dict) -> list[str]:
    if sorted(data) != sorted(ref_data):
        return [f"holds {sorted(set(data) ^ set(ref_data))} unlike the reference"]
    diff = [f"attribute {k} differs" for k in ref_attrs if attrs.get(k) != ref_attrs[k]]
    return diff + [f"{name} differs" for name, a in data.items()  # the owning rank may differ
                   if a is not None and name != "rank" and not np.array_equal(a, ref_data[name])]


def named_files(index: Path) -> set[str]:
    """The files an XDMF index names."""
    return {item.text.split(":")[0] for item in ET.parse(index).getroot().iter("DataItem")}


def xdmf_problems(index: Path, run: Path, known: dict[str, dict],
                  series: list[str]) -> list[str]:
    """What is wrong with an XDMF index: files or datasets it names that do not exist, or not
    of the stated shapes, and a hole: a file of ``series`` (in order) it leaves out before one
    it names. ``known``: {file name: {dataset: shape}} of the files verified."""
    grids = ET.parse(index).getroot().find("Domain").find("Grid").findall("Grid")
    items: dict[str, list] = {}  # file -> [(dataset path, shape)]: each file opened once
    for grid in grids:
        for item in grid.iter("DataItem"):
            name, path = item.text.split(":")
            shape = tuple(int(d) for d in item.get("Dimensions").split())
            items.setdefault(name, []).append((path.lstrip("/"), shape))
    named = [name in items for name in series]
    found = [f"{index.name} leaves out {name} but names a later file"
             for k, name in enumerate(series) if not named[k] and any(named[k + 1:])]
    for name, wanted in items.items():
        if not (run / name).exists():
            found.append(f"{index.name} names {name}, which does not exist")
            continue
        if name in known:
            shapes = known[name]
        else:
            with h5py.File(run / name, "r") as h5:
                shapes = {path: h5[path].shape for path, _ in wanted if path in h5}
        found += [f"{index.name} names {name}:{path} {shape}, not in the file"
                  for path, shape in wanted if shapes.get(path) != shape]
    return found


def same_checkpoint(a: Path, b: Path) -> bool:
    with h5py.File(a, "r") as x, h5py.File(b, "r") as y:
        return (x.attrs["step"] == y.attrs["step"] and sorted(x) == sorted(y)
                and all(np.array_equal(x[k][()], y[k][()]) for k in y))


def kill_loop(kills: int, ranks: int, work: Path, seed: int = 0, steps: int = 200,
              checkpoint_every: int = 20, say=print, sig: str = "KILL") -> dict:
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
    reference = {i: contents(p) for i, p in snapshot_files(ref).items()}
    assert sorted(reference) == list(range(first, first + steps + 1)), "reference series"
    verified: dict = {}
    say(f"reference: {steps} steps with a snapshot each in {window:.1f} s; {kills} SIG{sig} "
        f"in [0, {window:.1f}] s on {ranks} rank(s)")
    rng = random.Random(seed)
    counts = {"kills": 0, "while_writing": 0, "partial_file": 0, "completed": 0, "hung": 0,
              "unclean": 0, "corrupted": 0, "ranks": ranks, "signal": sig}
    shutil.rmtree(run, ignore_errors=True)
    while counts["kills"] < kills:
        own = (run / "checkpoint.h5").exists()
        options = ["--restart", str(run)] if own else ["--restart", str(prep), "--overwrite"]
        launched = time.time()
        proc = start(command(ranks, scene, run, *options))
        code, found = strike(proc, rng, sig, window, run, launched, counts)
        err = proc.stderr.read()
        proc.stderr.close()
        found += problems(run, reference, first, verified)
        if code == 0:
            counts["completed"] += 1
            if sorted(snapshot_files(run)) != sorted(reference):
                found.append("a completed run lacks snapshots")
            elif len(named_files(run / "particles.xdmf")) != len(reference):
                found.append("a completed run's particles.xdmf does not name every snapshot")
            if not same_checkpoint(run / "checkpoint.h5", ref / "checkpoint.h5"):
                found.append("a completed run ends in another state than the reference")
            shutil.rmtree(run)
        else:
            counts["kills"] += 1
            files = snapshot_files(run).values()
            counts["while_writing"] += any(p.stat().st_mtime >= launched for p in files)
            counts["partial_file"] += any((run / "snapshots").glob("*.tmp"))
            if sig != "KILL" and code is not None:
                unclean = stop_problems(code, err, sig, run)
                counts["unclean"] += bool(unclean)
                found += unclean
        if code not in (0, None) and sig == "KILL":
            found.append(f"the run exited {code}: {err.strip()[-300:]}")
        if found:
            counts["corrupted"] += any(not f.startswith(("hung", "stop:")) for f in found)
            say(f"kill {counts['kills']}: " + "; ".join(found[:5]))
            shutil.rmtree(run, ignore_errors=True)  # start over: one problem counted once
        if counts["kills"] % 50 == 0 and code != 0:
            say(f"{counts}")
    return counts


def strike(proc, rng, sig: str, window: float, run: Path, launched: float, counts):
    """Kill (or signal) the run at a random moment; (exit status or None if killed, problems)."""
    if sig == "KILL":
        try:
            return proc.wait(timeout=rng.uniform(0.0, window)), []
        except subprocess.TimeoutExpired:
            kill_all(proc, run)
            return None, []
    while proc.poll() is None and not any(p.stat().st_mtime >= launched
                                          for p in snapshot_files(run).values()):
        time.sleep(0.005)  # the handlers are installed once the run writes
    try:
        return proc.wait(timeout=rng.uniform(0.0, window)), []
    except subprocess.TimeoutExpired:
        pass
    number = getattr(signal, f"SIG{sig}")
    ranks = rank_pids(run)
    target = rng.choice([proc.pid, *ranks])
    # MPICH's mpiexec kills the job at a second signal (as a second Ctrl-C would): that is a
    # kill -9, the KILL loop's case; mpiexec gets one, a rank one to three
    repeats = 1 if target == proc.pid and ranks != [proc.pid] else rng.randint(1, 3)
    for _ in range(repeats):
        try:
            os.kill(target, number)
        except ProcessLookupError:
            break
        time.sleep(rng.uniform(0.0, 0.005))
    try:
        return proc.wait(timeout=30.0), []
    except subprocess.TimeoutExpired:
        counts["hung"] += 1
        kill_all(proc, run)
        return None, [f"hung: no exit within 30 s of SIG{sig} to pid {target}"]


def kill_all(proc, run: Path) -> None:
    """SIGKILL to the launcher's process group and to every rank (MPICH's mpiexec starts its
    proxy and ranks in sessions of their own, out of reach of killpg), then wait until no rank
    is left, so that the check never races a dying rank."""
    ranks = rank_pids(run)
    os.killpg(proc.pid, signal.SIGKILL)
    for pid in ranks:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    proc.wait()
    deadline = time.time() + 30.0
    while rank_pids(run) and time.time() < deadline:
        time.sleep(0.01)


def rank_pids(run: Path) -> list[int]:
    """The Python processes (ranks) of the run writing into ``run`` (mpiexec starts its ranks
    in process groups of their own)."""
    pids = []
    for entry in Path("/proc").iterdir():
        try:
            cmd = (entry / "cmdline").read_bytes().split(b"\0")
            if cmd[0] == sys.executable.encode() and str(run).encode() in cmd:
                pids.append(int(entry.name))
        except (OSError, ValueError, IndexError):
            continue
    return pids


def stop_problems(code: int, err: str, sig: str, run: Path) -> list[str]:
    """What is wrong with a signal stop: the status, a traceback, the final checkpoint."""
    found = []
    number = getattr(signal, f"SIG{sig}")
    if code not in (128 + number, -number):  # -number: it came during the interpreter's exit
        found.append(f"stop: exit status {code}: {err.strip()[-1500:]}")
    if "Traceback" in err:
        found.append("stop: a traceback")
    files = snapshot_files(run)
    try:
        with h5py.File(run / "checkpoint.h5", "r") as h5, \
                h5py.File(files[max(files)], "r") as last:
            if int(h5.attrs["step"]) != int(last.attrs["step"]):
                found.append(f"stop: the checkpoint (step {h5.attrs['step']}) is not the last "
                             f"snapshot's state (step {last.attrs['step']})")
    except (OSError, KeyError, ValueError) as e:
        found.append(f"stop: no final checkpoint and snapshot ({type(e).__name__}: {e})")
    return found


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
    ap.add_argument("--signal", default="KILL", choices=["KILL", "INT", "TERM"])
    ap.add_argument("--work", help="folder for the runs (default: a temporary one)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        counts = kill_loop(args.kills, args.ranks, Path(args.work or tmp), args.seed,
                           args.steps, args.checkpoint_every, sig=args.signal)
    print(f"SIG{args.signal} stops  while writing  partial file  completed runs  hung  unclean  "
          "corrupted")
    print(f"{counts['kills']:5d}  {counts['while_writing']:13d}  {counts['partial_file']:12d}  "
          f"{counts['completed']:14d}  {counts['hung']:4d}  {counts['unclean']:7d}  "
          f"{counts['corrupted']:9d}")
    print("RESULT " + json.dumps(counts))


if __name__ == "__main__":
    main()

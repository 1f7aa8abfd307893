"""Command line: ``pardem run SCENE.toml [--out DIR] [--end T] [--restart CHECKPOINT |
--from CHECKPOINT] [--overwrite]``,
``pardem check SCENE.toml`` (what a scene will do, before it runs), ``pardem average DIR [...]``
(ring averages from snapshots), ``pardem plot DIR [DIR ...]`` (the paper's figures),
``pardem render DIR`` (pictures), ``pardem warmup SCENE...`` (compile the kernels ahead of a
run), ``pardem --version``.

Stage: entry point. Errors in the user's input (scene, restart file, output folder) print one
line naming the problem and exit with status 2; a run that becomes invalid exits with status 3.

Under ``mpiexec -n P pardem run ...`` every rank runs this. Input errors and invalid runs are
detected on every rank alike (the checks are collective), so each rank exits with the same
status and rank 0 prints the message. Any other exception on any rank prints that rank's
traceback and calls ``MPI_Abort``: the job ends within seconds instead of hanging in a
collective.
"""

from __future__ import annotations

import argparse
import dataclasses
import errno
import shutil
import sys
import time
from pathlib import Path

from .cli_values import UNREADABLE, in_file, metres, seconds, unreadable


def main(argv: list[str] | None = None) -> int:
    from . import __version__

    parser = argparse.ArgumentParser(
        prog="pardem", description="pardem: 2D discrete-element simulation of a granular "
        "Couette shear cell, ring averaging and the paper's figures.")
    parser.add_argument("--version", action="version", version=f"pardem {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene")
    run.add_argument("scene", help="scene file (TOML)")
    run.add_argument("--out", help="output folder (default: runs/<scene name>)")
    run.add_argument("--end", type=seconds, help="end time in s (default: the scene's [time] end)")
    start = run.add_mutually_exclusive_group()
    start.add_argument("--restart", help="checkpoint file (or run folder) to continue from, "
                       "exactly (the same scene)")
    start.add_argument("--from", dest="branch", metavar="CHECKPOINT",
                       help="checkpoint file (or run folder) of a prepared run to branch a new "
                            "run from: its particles, time and contact history with this "
                            "scene's material and drive ([contact], [effects], omega_inner)")
    run.add_argument("--overwrite", action="store_true",
                     help="replace the run in the output folder (refused otherwise, except a "
                          "restart of the same scene, which continues it)")
    run.add_argument("--quiet", action="store_true", help="no progress line")
    run.add_argument("--timing", action="store_true",
                     help="time each stage of the step loop and print us per step of each, "
                          "per rank, at the end (timers compiled in only with this option)")
    run.add_argument("--cut", default="auto",
                     help="how the annulus is cut among MPI ranks: 'auto' (the cut with the "
                          "fewest ghosts per rank), 'sectors', or RINGSxSECTORS such as 2x4; "
                          "results are the same bits whatever the cut")
    warm = sub.add_parser("warmup", help="compile (and cache) the kernels of scenes' sets of "
                          "effects now, e.g. before a batch job, so that their runs start at once; under "
                          "mpiexec -n P: what a P-rank run needs")
    warm.add_argument("scenes", nargs="+", help="scene files (TOML)")
    check = sub.add_parser("check", help="print the resolved scene, t_c, dt, volume fraction, "
                           "steps and an estimated run time (runs nothing)")
    check.add_argument("scene", help="scene file (TOML)")
    avg = sub.add_parser("average", help="ring-average the snapshots of a run folder")
    avg.add_argument("run_dir", help="run folder (scene.toml + snapshots/)")
    avg.add_argument("--start", type=seconds, help="s (default: the scene's [averaging] start)")
    avg.add_argument("--end", type=seconds, help="s (default: the scene's [averaging] end)")
    avg.add_argument("--ring-width", type=metres,
                     help="m (default: the scene's, or the smallest free diameter / 8)")
    avg.add_argument("--weighting", choices=["slice", "exact", "centre", "gaussian"])
    avg.add_argument("--displacement", choices=["spring", "eta"],
                     help="tangential part of the contact displacement in eps and kappa: the "
                          "elastic spring xi (default: the scene's) or the total tangential "
                          "displacement eta (eq. 1.3 read literally)")
    avg.add_argument("--out", help="folder for rings.h5/rings.csv (default: RUN_DIR/offline)")
    plot = sub.add_parser("plot", help="the paper's figures (PNG) from ring averages")
    plot.add_argument("run_dirs", nargs="+", help="run folder(s) with rings.h5 (several: "
                      "one figure set comparing them)")
    plot.add_argument("--label", nargs="+", help="legend label of each run, in order "
                      "(default: the run folder's name)")
    plot.add_argument("--out", help="folder for the PNGs (default: RUN_DIR/figures)")
    pictures = sub.add_parser("render", help="PNG pictures of a run folder: disks, force "
                              "chains, ring fields (needs pyvista: the viz extra)")
    pictures.add_argument("run_dir", type=Path)
    pictures.add_argument("--snapshot", type=int, default=-1,
                          help="index in time order (default: the last)")
    pictures.add_argument("--color", choices=["speed", "spin"], default="speed")
    pictures.add_argument("--fields", nargs="*", default=["nu", "v_phi", "tr_sigma", "mu_c"],
                          help="ring fields to draw (rings.vtu)")
    pictures.add_argument("--size", type=int, default=1200, help="image height (pixels)")
    pictures.add_argument("--out", type=Path, help="default RUN_DIR/figures")
    args = parser.parse_args(argv)
    if args.command == "render":
        try:  # pyvista (VTK) only here: every other command starts without it
            from .render import render
        except ImportError as e:
            sys.stderr.write(f"pardem: error: pardem render needs pyvista ({e}); install it "
                             "with: pip install -e \".[viz]\"\n")
            return 2
        try:
            return render(args)
        except UNREADABLE + (RuntimeError,) as e:
            sys.stderr.write(f"pardem: error: {unreadable(args.run_dir, e)}\n")
            return 2
    if args.command == "average":
        return _average(args)
    if args.command == "plot":
        return _plot(args)
    if args.command == "check":
        return _check(args)
    if args.command == "warmup":
        return _warmup(args)
    t_start = time.perf_counter()
    from .compile_watch import CompileWatch, compile_label
    from .parallel import abort, on_root, rank_of, size_of, world
    from .input.scene import SceneError
    from .input.scene_file import load_scene
    from .simulation import Simulation, SimulationError
    from .stop import Interrupted, catching_signals, raise_on_sigterm, release_sigterm

    comm = world()  # None on one process: MPI is not loaded
    rank = rank_of(comm)
    root = rank == 0
    out = Path(args.out or "runs")
    # a batch system's SIGTERM during the set-up or a compile ends the command as a Ctrl-C
    # there does (one line, 128 + its number), not silently by the signal
    sigterm = raise_on_sigterm()
    try:
        scene = load_scene(args.scene)
        if args.branch is not None and args.end is not None:  # the branch checks the end
            scene = dataclasses.replace(scene, time=dataclasses.replace(scene.time,
                                                                         end=args.end))
        out = Path(args.out) if args.out else Path("runs") / scene.info.name
        on_root(comm, _check_writable, out)
        watch = CompileWatch(compile_label(scene, size_of(comm)), report=_say if root else None)
        if root:
            _say(f"pardem: {scene.info.name}: building the initial state; kernels load from the "
                 f"cache, or compile on the first run of this set of effects ({watch.plan()})")
        with watch:  # numba compiles at first calls: in the set-up and the first steps
            sim = Simulation(scene, out_dir=out, restart=args.restart, comm=comm,
                             overwrite=args.overwrite, cut=args.cut, branch=args.branch,
                             timing=args.timing)
            if root:
                compiled = (f" (compiled {watch.kernels} kernels in {watch.seconds:.0f} s)"
                            if watch.kernels else "")
                watch.reported = watch.kernels
                _say(f"pardem: {scene.info.name}: {sim.n_free} particles, dt = {sim.dt:.4g} s, "
                     f"{sim.decomp.describe()}, ready in {time.perf_counter() - t_start:.2f} s"
                     f"{compiled}; output in {out}")
            # SIGINT/SIGTERM: every rank stops at a step, checkpointed; this process only ends then
            with catching_signals(restore=argv is not None):  # argv given: called from Python
                sim.run(end=args.end, progress=not args.quiet)
    except SceneError as e:
        if root:
            sys.stderr.write(f"pardem: error: {in_file(e, args.scene)}\n")
        return 2
    except SimulationError as e:
        if root:
            sys.stderr.write(f"pardem: run stopped: {e}\n")
        return 3
    except Interrupted as e:
        if root:
            sys.stderr.write(f"pardem: {e}; the checkpoint {out / 'checkpoint.h5'} holds this "
                             f"state: continue with --restart {out}\n")
        return 128 + e.signum
    except KeyboardInterrupt as e:  # Ctrl-C or SIGTERM outside the loop: set-up, compiling
        import signal

        for sig in (signal.SIGINT, signal.SIGTERM):  # a second one must not skip Abort
            signal.signal(sig, signal.SIG_IGN)
        signum = getattr(e, "signum", signal.SIGINT)  # stop.Terminated: SIGTERM
        who = "" if comm is None else f"rank {rank}: "
        sys.stderr.write(f"pardem: {who}interrupted ({signal.Signals(signum).name}) outside "
                         f"the time-step loop; {out / 'checkpoint.h5'} holds the last "
                         "checkpoint, if any\n")
        sys.stderr.flush()
        abort(comm, 128 + signum)
        return 128 + signum
    except BaseException as e:
        # a full disk, a quota, or a file-size limit (ulimit -f): the same for the user
        full = isinstance(e, OSError) and e.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
        if full:  # checkpoints go to a temporary name first: the last one is whole
            last = (f"the last complete checkpoint is {out / 'checkpoint.h5'}"
                    if (out / "checkpoint.h5").exists() else "no checkpoint was written yet")
            room = ("raise the file-size limit (ulimit -f)" if e.errno == errno.EFBIG
                    else "free space")
            sys.stderr.write(f"pardem: error: rank {rank}: {e.strerror} while writing "
                             f"{e.filename or 'the output'}; {last}: {room} and continue "
                             f"with --restart {out}\n")
        if comm is not None:
            import signal
            import traceback

            signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not skip Abort
            if not full:
                sys.stderr.write(f"pardem: rank {rank} failed:\n{traceback.format_exc()}")
            sys.stderr.flush()
            abort(comm, 4 if full else 1)  # mpiexec passes the code on: 4 as documented
        if full:
            return 4
        raise
    finally:
        release_sigterm(sigterm, restore=argv is not None)  # argv given: called from Python
    return 0


def _say(line: str) -> None:
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


def _warmup(args) -> int:
    """A few steps of each scene with every writer on, in a scratch folder: numba compiles what
    a run of that scene needs and caches it on disk (~/.cache/pardem/numba). Under ``mpiexec
    -n P`` it compiles what a P-rank run needs (the step loop with the ghost exchange)."""
    import tempfile

    from .compile_watch import CompileWatch, compile_label
    from .parallel import abort, barrier, broadcast, rank_of, size_of, world
    from .input.scene import SceneError
    from .input.scene_file import load_scene
    from .warmup import warm_up

    comm = world()
    root = rank_of(comm) == 0
    for path in args.scenes:
        t0 = time.perf_counter()
        tmp = tempfile.mkdtemp(prefix="pardem-warmup-") if root else None
        tmp = broadcast(comm, tmp)
        try:
            scene = load_scene(path)
            with CompileWatch(compile_label(scene, size_of(comm)),
                              report=_say if root else None) as watch:
                warm_up(scene, tmp, comm)
        except SceneError as e:  # in the file, or found building the state (placement, dt)
            if root:
                sys.stderr.write(f"pardem: error: {in_file(e, path)}\n")
            return 2
        except BaseException:
            if comm is not None:
                import traceback

                sys.stderr.write(f"pardem: warmup failed:\n{traceback.format_exc()}")
                abort(comm)
            raise
        finally:
            barrier(comm)
            if root:
                shutil.rmtree(tmp, ignore_errors=True)
        if root:
            ranks = "" if comm is None else f" for {size_of(comm)} ranks"
            how = (f"compiled {watch.kernels} kernels in {watch.seconds:.0f} s" if watch.kernels
                   else "all from the cache")
            print(f"{path}: kernels ready{ranks} in {time.perf_counter() - t0:.1f} s ({how})")
    return 0


def _check(args) -> int:
    from .check import describe
    from .input.scene import SceneError
    from .input.scene_file import load_scene

    try:
        print(describe(load_scene(args.scene)))
    except SceneError as e:
        sys.stderr.write(f"pardem: error: {in_file(e, args.scene)}\n")
        return 2
    return 0


def _average(args) -> int:
    from averaging.offline import average_run

    from .input.scene import SceneError

    try:
        avg = average_run(args.run_dir, args.start, args.end, args.ring_width, args.weighting,
                          args.displacement)
        out = Path(args.out) if args.out else Path(args.run_dir) / "offline"
        _check_writable(out)
        avg.write(out)
    except (SceneError, FileNotFoundError) as e:
        sys.stderr.write(f"pardem: error: {e}\n")
        return 2
    except UNREADABLE as e:
        if isinstance(e, OSError) and e.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
            sys.stderr.write(f"pardem: error: {e.strerror} while writing {e.filename}; "
                             "nothing was replaced: free space and average again\n")
            return 4
        sys.stderr.write(f"pardem: error: {unreadable(args.run_dir, e)}\n")
        return 2
    sys.stderr.write(f"pardem: {len(avg.samples)} snapshots averaged into {avg.n_rings} rings: "
                     f"{out / 'rings.csv'}\n")
    return 0


def _plot(args) -> int:
    from averaging.plots import make_figures
    from averaging.report import load_run

    labels = args.label or [None] * len(args.run_dirs)
    if len(labels) != len(args.run_dirs):
        sys.stderr.write(f"pardem: error: --label: {len(labels)} labels for "
                         f"{len(args.run_dirs)} run folders\n")
        return 2
    runs = []
    for d, label in zip(args.run_dirs, labels):
        d = Path(d)
        where = d if (d / "rings.h5").exists() else d / "offline"
        if not (where / "rings.h5").exists():
            sys.stderr.write(f"pardem: error: {d}: no rings.h5 (run a scene with an "
                             "[averaging] table, or `pardem average` it first)\n")
            return 2
        try:
            runs.append(load_run(where, label=label or (d.name if where != d else None)))
        except UNREADABLE as e:
            sys.stderr.write(f"pardem: error: {unreadable(where, e)}\n")
            return 2
    out = Path(args.out) if args.out else Path(args.run_dirs[0]) / "figures"
    for path in make_figures(runs, out):
        print(path)
    return 0


def _check_writable(out: Path) -> None:
    from .input.scene import SceneError

    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".pardem-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise SceneError(f"--out {out}: output folder is not writable ({e.strerror})") from e


if __name__ == "__main__":
    sys.exit(main())

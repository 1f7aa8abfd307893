"""Command line: ``pardem run SCENE.toml [--out DIR] [--end T] [--restart CHECKPOINT]``.

Stage: entry point. Errors in the user's input (scene, restart file, output folder) print one
line naming the problem and exit with status 2; a run that becomes invalid exits with status 3.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="pardem", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene")
    run.add_argument("scene", help="scene file (TOML)")
    run.add_argument("--out", help="output folder (default: runs/<scene name>)")
    run.add_argument("--end", type=float, help="end time in s (default: the scene's [time] end)")
    run.add_argument("--restart", help="checkpoint file to continue from")
    run.add_argument("--quiet", action="store_true", help="no progress line")
    args = parser.parse_args(argv)
    t_start = time.perf_counter()
    from .scene import SceneError, load_scene
    from .simulation import Simulation, SimulationError

    try:
        scene = load_scene(args.scene)
        out = Path(args.out) if args.out else Path("runs") / scene.info.name
        _check_writable(out)
        sim = Simulation(scene, out_dir=out, restart=args.restart)
        sys.stderr.write(f"pardem: {scene.info.name}: {sim.n_free} particles, dt = {sim.dt:.4g} s,"
                         f" ready in {time.perf_counter() - t_start:.2f} s; output in {out}\n")
        sim.run(end=args.end, progress=not args.quiet)
    except SceneError as e:
        sys.stderr.write(f"pardem: error: {e}\n")
        return 2
    except SimulationError as e:
        sys.stderr.write(f"pardem: run stopped: {e}\n")
        return 3
    return 0


def _check_writable(out: Path) -> None:
    from .scene import SceneError

    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".pardem-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise SceneError(f"--out {out}: output folder is not writable ({e.strerror})") from e


if __name__ == "__main__":
    sys.exit(main())

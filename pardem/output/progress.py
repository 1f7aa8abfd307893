"""The run's log (DIR/log.txt) and progress line (stderr), and the per-stage time breakdown.

Stage: output (rank 0 only). The log is opened and closed for every line, so a crash loses
nothing already logged; a restart appends to the same log.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

from ..boundaries.walls import wall_work_note
from ..core.timestep import off_step_text
from ..core.timing import CLOSING, DRIFT, FORCES, PACK, REFRESH, STEPS, UNPACK


def log_line(out_dir: Path | None, text: str) -> None:
    """Append a time-stamped line to out_dir/log.txt (nothing without a folder)."""
    if out_dir is None:
        return
    stamp = time.strftime("%Y-%m-%d %H:%M:%S")
    out_dir.mkdir(parents=True, exist_ok=True)
    with open(out_dir / "log.txt", "a") as f:
        f.write(f"{stamp} {text}\n")


def start_notes(scene, step_length, end: float, averaging: bool) -> list[str]:
    """What a run rounds or leaves out of what the scene asks for: output times that are not
    a whole number of steps, an [averaging] window past the run's end; and rings whose wall
    disks will cost more time than the free disks."""
    notes = [] if wall_work_note(scene) is None else [wall_work_note(scene)]
    off = off_step_text(scene, step_length)
    if off:
        notes.append(f"{off}: rounded to the nearest step")
    cfg = scene.averaging
    if averaging and cfg.end > end:
        notes.append(f"[averaging] end = {cfg.end:g} s lies past this run's end {end:g} s: the "
                     f"averages cover {cfg.start:g} s to {end:g} s" if cfg.start < end else
                     f"[averaging] starts at {cfg.start:g} s, after this run's end {end:g} s: "
                     "no ring averages")
    return notes


def progress_line(sim, elapsed: float, steps: int, end_step: int, e_kin: float,
                  overlap: float) -> str:
    """Simulated time, rate, ETA, kinetic energy and largest overlap of a running Simulation.
    The rate (and the ETA from it) is that of the last ``steps`` steps, taken in ``elapsed``
    seconds (since the previous report): a rate averaged from the start would count the
    first chunk's set-up and hide a run that slows down as it compacts."""
    step = sim.step
    rate = steps / elapsed if elapsed > 0 else 0.0
    eta = (end_step - step) / rate if rate > 0 else math.inf
    return (f"t = {sim.time:9.3f} / {end_step * sim.dt:.3f} s | {rate:9.0f} steps/s | "
            f"{rate * sim.n_free / 1e6:6.2f} M particle-steps/s | ETA {eta:7.1f} s | "
            f"E_kin {e_kin:.3e} J | max overlap {100 * overlap:.2f}% d")


def show_progress(line: str) -> None:
    """On a terminal, one line rewritten in place; otherwise (a batch job's log, a pipe) one
    plain line per report, like LAMMPS' thermo output."""
    if sys.stderr.isatty():
        sys.stderr.write("\r" + line + " ")
    else:
        sys.stderr.write(line + "\n")
    sys.stderr.flush()


def end_progress() -> None:
    """Close the line show_progress rewrites in place (a terminal only)."""
    if sys.stderr.isatty():
        sys.stderr.write("\n")


def breakdown(sim) -> str:
    """Wall time per stage on this rank, with the waiting on neighbours under MPI."""
    d = sim.decomp
    total = sum(sim.timers.values()) or 1.0
    rows = [f"  {k:<20s} {v:9.3f} s  {100 * v / total:5.1f} %" for k, v in sim.timers.items()]
    if d.parallel:  # part of forces+integration
        wait = float(d.wait[0])
        rows.insert(1, f"    of which waiting on neighbours {wait:9.3f} s  "
                       f"{100 * wait / total:5.1f} % (exchange latency + imbalance)")
    builds = f"{sim.n_rebuilds} neighbour builds"
    if d.parallel:
        builds += f", {d.n_exchanges} of them with an exchange"
    return "\n".join([f"time per stage on rank {d.rank} ({sim.step} steps, {builds}; "
                      f"{d.describe()}):", *rows])


def report(sim, since: list, end_step: int, progress: bool, overlap: float) -> None:
    """The progress line (collective: the kinetic energy; ``overlap``, the largest, is every
    rank's already); rank 0 logs and shows it."""
    # the rate window runs from the end of the last report to the start of this one
    elapsed, steps = time.perf_counter() - since[0], sim.step - since[1]
    e_kin = sim.kinetic_energy()  # collective
    since[:] = time.perf_counter(), sim.step
    if sim.decomp.rank != 0:
        return
    line = progress_line(sim, elapsed, steps, end_step, e_kin, overlap)
    sim.log(line)
    if progress:
        show_progress(line)


STAGE_COLUMNS = ("kick+drift", "refresh", "(wait", "pack", "unpack)", "forces",
                 "closing kick", "step", "rebuild", "(exchange)")


def stage_table(sim) -> str | None:
    """Microseconds per step of each stage of the step loop on every rank (collective; the
    text on rank 0, None elsewhere), from the timers a ``timing`` run compiles in
    (``core/timing.py``) and the builds' Python timers. "step" is the compiled call's wall
    time, the stages plus the timers' own cost; the refresh holds the wait (for the
    neighbours' blocks, and any Allreduce), pack and unpack; the rebuild holds the exchange."""
    t, w = sim.clock.deep, sim.decomp.wait
    steps = max(t[STEPS], 1.0)
    d = sim.decomp
    seconds = [t[DRIFT], t[REFRESH], w[0], w[PACK], w[UNPACK], t[FORCES], t[CLOSING],
               sim.timers["forces+integration"], sim.timers["neighbour rebuild"],
               sim.rebuilder.exchange_seconds]
    rows = d.join(1e6 * np.array([seconds]) / steps)
    if d.rank != 0:
        return None
    head = "  rank " + "".join(f"{c:>9s}" if len(c) < 9 else f" {c}" for c in STAGE_COLUMNS)
    lines = [f"us per step of each stage ({int(t[STEPS])} steps timed on rank 0, "
             f"{sim.n_rebuilds} neighbour builds):", head]
    for r, row in enumerate(rows):
        lines.append(f"  {r:4d} " + "".join(
            f"{v:{max(9, len(c) + 1)}.2f}" for v, c in zip(row, STAGE_COLUMNS)))
    return "\n".join(lines)

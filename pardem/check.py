"""``pardem check SCENE``: what a scene will do, before it runs (no step kernel is compiled).

Stage: entry point. Places the particles as a run would (a count the start cannot hold is
refused here too). Prints the resolved scene (every default filled in), how the particles
were placed, the contact time of the stiffest pair, the time step and steps per contact, the global volume fraction, the
number of steps and particle-steps, an estimate of the wall time from a reference rate
(``REFERENCE_RATE``: an order of magnitude, not a promise; the machine and the state of the
packing change it by a factor of two) with how it was obtained and what the machine's load
does to it, and the scene's warnings (input/sanity.py).
"""

from __future__ import annotations

import os


from .core import memory
from .core.memory import need_text, needed_bytes, size_text
from .input.placement import PLACEMENTS, initial_configuration
from .input.scene import Scene
from .input.scene_file import scene_to_toml
from .core.scales import smallest_contact_time
from .core.stability import rounded, stability_limit
from .core.timestep import off_step_text, resolve_step
from .boundaries.walls import RINGS, global_volume_fraction, wall_work_note
from .input.sanity import density_warning
from .input.species import free_area
from .parallel import usable_cores

WALL_DISK_COST = ("measured at 14-39 ns per wall disk and step on this 2-core machine (50,000 "
                  "to 10^6 inner wall disks), against ~40 ns per free disk at the reference rate")
REFERENCE_WALL_SHARE = 319 / 2939
"""Wall disks per free disk of couette_B, whose steps the reference rate includes."""
REFERENCE_RATE = 25e6
"""Particle-steps per second of one rank on couette_B (docs/scaling.md, 2-core machine)."""
REFERENCE = ("not timed here (nothing is compiled): the work over a reference rate, from one "
             "rank of an otherwise idle 2-core machine on couette_B (2,939 disks), 23 M "
             "particle-steps/s after its compression and 40 M in steady shear (medians of "
             "20000-step runs, docs/scaling.md); a denser or larger cell is slower per particle "
             "(a 300k-disk cell ran at 0.44 of B's rate)")


def volume_fraction(scene: Scene) -> float | None:
    """Global volume fraction of a couette scene at its final outer radius: free disks plus
    half of every wall disk, over pi (R_o^2 - R_i^2) (the paper's v-bar); None for free
    scenes."""
    g = scene.geometry
    return None if g is None else global_volume_fraction(
        g, free_area(scene.species, scene.info.seed, scene.contact.height))


def describe(scene: Scene) -> str:
    """The report ``pardem check`` prints (SceneError if the scene cannot run)."""
    step = resolve_step(scene)  # also refuses ring speeds the contact law cannot follow
    dt = float(step)
    t_c = smallest_contact_time(scene)
    n = scene.n_free
    steps = int(round(scene.time.end / dt))
    walls = RINGS.disks(scene).radius.size  # moved at every step, on every rank
    # the reference rate was measured with B's wall disks: more than its share cost extra
    extra = max(walls - REFERENCE_WALL_SHARE * n, 0.0)
    work = n * steps
    one = (n + extra) * steps / REFERENCE_RATE
    limit, mode = stability_limit(scene)
    lines = [scene_to_toml(scene).rstrip(), "",
             f"# particles (free): {n}, {_placement(scene)}",
             f"# contact time of the lightest pair t_c = {t_c:.6g} s; dt = {dt:.6g} s "
             f"= t_c / {t_c / dt:.4g}",
             f"# stability limit dt <= {rounded(limit, 4, down=True)} s = t_c / "
             f"{rounded(t_c / limit, 3, down=False)} (set by {mode}): "
             f"dt is {limit / dt:.3g} x below it"]
    lines.append(_output_times(scene, step))
    nu = volume_fraction(scene)
    if nu is not None:
        lines.append(f"# global volume fraction (free disks + half of each wall disk, at the "
                     f"final outer radius) = {nu:.4f}")
    two = (n / 1.7 + extra) * steps / REFERENCE_RATE
    lines.append(f"# {steps} steps to t = {scene.time.end:g} s: {work:.4g} particle-steps, "
                 f"roughly {_duration(one)} on 1 rank, "
                 f"{_duration(two)} on 2 (at "
                 f"{REFERENCE_RATE / 1e6:.0f} M particle-steps/s per rank; plus about a minute "
                 "of compilation on a first run)")
    if extra >= 0.1 * n:
        lines.append(f"# the estimate counts the rings' {walls} wall disks, beyond the share "
                     "of the reference cell (319 for 2,939 free disks), as free disks: every "
                     f"rank moves each at every step, {WALL_DISK_COST}")
    lines.append(f"# the estimate is {REFERENCE}")
    lines.append(load_note(one, *os.getloadavg()[:1], len(usable_cores())))
    lines.append(f"# memory: about {size_text(needed_bytes(scene))} per rank at its peak "
                 f"({need_text(scene)})")
    if wall_work_note(scene):
        lines.append(f"# note: {wall_work_note(scene)}")
    warning = density_warning(scene)
    if warning:
        lines.append(f"# warning: {warning}")
    return "\n".join(lines)


def _placement(scene: Scene) -> str:
    """How a run places the particles (a count the start cannot hold is refused, as by run);
    not tried where the scene does not fit in this node's memory, which run refuses first."""
    available = memory.available_bytes()
    if available is not None and needed_bytes(scene) > available:
        return "not placed here: the scene does not fit in this node's memory (below)"
    return PLACEMENTS[initial_configuration(scene).placement]


def load_note(seconds: float, load: float, cores: int) -> str:
    """What the machine's load (the 1-minute load average: processes running or waiting for a
    core) does to ``seconds`` on one rank: a new process gets about cores / (load + 1) of a
    core when that is below one."""
    share = cores / (load + 1.0)
    head = f"# this machine: {cores} cores, load average {load:.2f} over the last minute: "
    if share >= 1.0:
        return head + "a rank would have a core to itself, as in the reference"
    return (head + f"a rank would get about {share:.2f} of a core, so expect about "
            f"{_duration(seconds / share)} on 1 rank; several ranks beside other jobs slow far "
            "more, each waiting for the others at every step (docs/warnings.md)")


def _output_times(scene: Scene, step) -> str:
    off = off_step_text(scene, step)
    return (f"# output times rounded to the nearest step: {off}" if off else
            "# output at exactly the times named (each a whole number of steps)")


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"

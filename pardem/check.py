"""``pardem check SCENE``: what a scene will do, before it runs (nothing is compiled).

Stage: entry point. Prints the resolved scene (every default filled in), the contact time of
the stiffest pair, the time step and steps per contact, the global volume fraction, the
number of steps and particle-steps, an estimate of the wall time from a reference rate
(``REFERENCE_RATE``: an order of magnitude, not a promise; the machine and the state of the
packing change it by a factor of two) with how it was obtained and what the machine's load
does to it, and the scene's warnings (input/sanity.py).
"""

from __future__ import annotations

import os


from .core.memory import needed_bytes, particle_count, size_text
from .input.scene import Scene
from .input.scene_file import scene_to_toml
from .core.scales import smallest_contact_time
from .core.stability import stability_limit
from .core.timestep import off_step_text, resolve_step
from .boundaries.walls import global_volume_fraction
from .input.sanity import density_warning
from .input.species import free_area
from .parallel import usable_cores

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
    work = n * steps
    limit, mode = stability_limit(scene)
    lines = [scene_to_toml(scene).rstrip(), "",
             f"# particles (free): {n}",
             f"# contact time of the lightest pair t_c = {t_c:.6g} s; dt = {dt:.6g} s "
             f"= t_c / {t_c / dt:.4g}",
             f"# stability limit dt <= {limit:.4g} s = t_c / {t_c / limit:.3g} (set by {mode}): "
             f"dt is {limit / dt:.3g} x below it"]
    lines.append(_output_times(scene, step))
    nu = volume_fraction(scene)
    if nu is not None:
        lines.append(f"# global volume fraction (free disks + half of each wall disk, at the "
                     f"final outer radius) = {nu:.4f}")
    lines.append(f"# {steps} steps to t = {scene.time.end:g} s: {work:.4g} particle-steps, "
                 f"roughly {_duration(work / REFERENCE_RATE)} on 1 rank, "
                 f"{_duration(work / REFERENCE_RATE / 1.7)} on 2 (at "
                 f"{REFERENCE_RATE / 1e6:.0f} M particle-steps/s per rank; plus about a minute "
                 "of compilation on a first run)")
    lines.append(f"# the estimate is {REFERENCE}")
    lines.append(load_note(work / REFERENCE_RATE, *os.getloadavg()[:1], len(usable_cores())))
    lines.append(f"# memory: about {size_text(needed_bytes(scene))} per rank at set-up "
                 f"({particle_count(scene)} particles with the wall disks)")
    warning = density_warning(scene)
    if warning:
        lines.append(f"# warning: {warning}")
    return "\n".join(lines)


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

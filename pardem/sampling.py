"""What the averaging package may use of pardem: one interface between a run and the
continuum fields built from it.

averaging/ is written on top of pardem and reaches it only through this module
(tests/test_layout.py checks it), so pardem's internals can move without touching the
averaging, and a reader sees in one place what the averaging assumes about a run:

- the scene: ``load_scene``, ``SceneError``, ``ring_width`` (the default ring width),
  ``ring_width_problem``, ``normal_stiffness`` (k'_n's stiffness), ``resolve_dt`` and
  ``volume_fraction``;
- which steps are samples: ``sample_range``, ``is_sample_step``;
- particles and contacts as written: ``read_snapshots``, the kinds ``FREE``,
  ``INNER_WALL`` and ``OUTER_WALL``;
- how to write: ``writing`` and ``size_of`` (atomic files) and ``JIT`` (numba's options,
  so that averaging kernels share pardem's cache).
"""

from __future__ import annotations

from .check import volume_fraction
from .input.errors import SceneError
from .core.jit import JIT
from .output.atomic import size_of, writing
from .output.snapshots import read_snapshots
from .output.writers import is_sample_step, sample_range
from .core.scales import normal_stiffness
from .input.scene_file import load_scene
from .input.schema import ring_width_problem
from .core.state import FREE, INNER_WALL, OUTER_WALL
from .core.timestep import resolve_dt

__all__ = ["FREE", "INNER_WALL", "JIT", "OUTER_WALL", "SceneError", "is_sample_step",
           "load_scene", "normal_stiffness", "read_snapshots", "resolve_dt", "ring_width",
           "ring_width_problem", "sample_range", "size_of", "volume_fraction", "writing"]


def ring_width(scene) -> float:
    """[averaging] ring_width (m), "auto": the smallest free-particle diameter / 8 (the
    paper's d_small/8)."""
    cfg = scene.averaging
    return (cfg.ring_width if cfg is not None and cfg.ring_width is not None
            else scene.min_free_diameter / 8.0)

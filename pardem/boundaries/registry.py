"""The registry of boundaries (the protocol: protocol.py) and what the set-up asks of all of
them together.

Stage: set-up. Wall disks follow the free disks in gid order, boundary by boundary in the
order of ``BOUNDARIES`` (the rings first: their disks kept the gids they had before other
boundaries existed). Adding a boundary: its module (descriptor, disks, scene keys and checks),
its entry here, and a kinematics branch in ``walls.place_wall_disks`` if its disks move.
"""

from __future__ import annotations

import numpy as np

from .protocol import Boundary, Glued
from .wall_file import WALL_FILE
from .walls import RINGS

BOUNDARIES: tuple[Boundary, ...] = (RINGS, WALL_FILE)


def glued_disks(scene) -> Glued:
    """Every boundary's wall disks at t = 0, in gid order."""
    parts = [b.disks(scene) for b in BOUNDARIES]
    return Glued(np.vstack([p.x for p in parts]), np.concatenate([p.radius for p in parts]),
                 np.concatenate([p.kind for p in parts]).astype(np.int8),
                 np.concatenate([p.phi0 for p in parts]))


def wall_disk_count(scene) -> int:
    """How many wall disks a scene has, over every boundary."""
    return sum(b.disks(scene).radius.size for b in BOUNDARIES)


def moving_disks(scene) -> bool:
    """Whether a boundary whose disks move has disks in the scene: the step loop places them
    and the lists are built with a wall skin (Params.wall_disks)."""
    return any(b.moves and b.disks(scene).radius.size for b in BOUNDARIES)


def flat_surfaces(scene) -> bool:
    """Whether the scene has a boundary with a flat contact surface (StepOptions.walls)."""
    return any(b.surface and b.present(scene) for b in BOUNDARIES)

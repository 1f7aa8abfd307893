"""The boundary protocol: what pardem knows of one kind of boundary, declared once.

Stage: set-up (the descriptors) and kernels (the compiled side). A boundary holds the free
disks in with a flat surface, with disks glued to it, or both, and prescribes how they move.
Its ``Boundary`` descriptor says:

    name      its name in messages and the manual
    keys      the scene keys that set it up
    kinds     the ``Particles.kind`` codes of the disks glued to it (state.py)
    disks     its glued disks in a scene at t = 0 (``Glued``; none if the scene has no such
              boundary): they become wall disks, infinitely massive rows after the free ones
    moves     whether its disks move: the step loop then places them at every step and the
              lists are built with a wall skin that covers their travel (Params.wall_disks,
              registry.moving_disks)
    surface   whether it has a flat contact surface (the ring contacts, Pairs.wall; compiled
              in by StepOptions.walls, registry.flat_surfaces)
    present   whether a scene has this boundary

The compiled side is small records and dispatches, as for the normal law (contact/normal.py):

    kinematics  ``walls.place_wall_disks``: a wall disk's place, velocity and spin at time t,
                chosen by its kind; the disks of a boundary that does not move keep what they
                were given at set-up, with no code at all
    surface     ``walls.ring_surface`` and ``surface_motion`` on the ``walls.Rings`` record:
                where the flat surface
                is, a disk's overlap and unit normal with it, the surface's velocity and spin
    travel      ``integrate.wall_travel``: how far the moving disks went since the last build

The flat surface and the moving disks are compiled in only when a scene has rings
(``StepOptions.walls``, ``Params.wall_disks``); a boundary of fixed disks needs neither, so
the step loop, the pair loop and the exchange treat its disks as any other wall disk. The
registry of boundaries is ``registry.BOUNDARIES``; docs/extending.md, "Adding a boundary",
walks through the file of fixed disks (``wall_file.py``).
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np


class Glued(NamedTuple):
    """A boundary's wall disks at t = 0: x [k,2] (m), radius [k] (m), kind [k] int8 (its
    kinds), phi0 [k] (rad: a ring disk's angle on its ring, 0 for others)."""

    x: np.ndarray
    radius: np.ndarray
    kind: np.ndarray
    phi0: np.ndarray


NO_DISKS = Glued(np.zeros((0, 2)), np.zeros(0), np.zeros(0, np.int8), np.zeros(0))


class Boundary(NamedTuple):
    """One kind of boundary (module docstring)."""

    name: str
    keys: tuple[str, ...]
    kinds: tuple[int, ...]
    disks: Callable[..., Glued]
    moves: bool
    surface: bool
    present: Callable[..., bool]
    summary: str = ""

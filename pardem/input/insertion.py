"""Random sequential insertion of disks in an annulus, each by its own size.

Stage: set-up (input/placement.py). Disks go in largest first, each at uniformly random
points of the ring band its centre may occupy (clear of both rings by its own radius) until
one overlaps no disk placed before it; a grid of cells two largest radii wide finds the disks
a trial point can touch. In 2D such insertion stops near an area fraction of 0.55 (0.547 for
equal disks, Hinrichsen, Feder and Jossang 1986), so the dilute starts of a shear cell (0.44
for the paper's cells) fill at a few trials per disk; a start too dense for it is refused
with how far it got.

Own module with no imports from the package but the compile options: the kernel cache is keyed
by the kernels' source files and what they import (core/jit.py).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..core.jit import JIT


@nb.njit(**JIT)
def insert_disks(radius, lo, hi, seed, max_trials):
    """Centres ``x`` [n,2] for disks of ``radius`` (placed in the order given: largest first
    is the caller's), each centre at distance lo[i] <= |x| <= hi[i] from the origin and no two
    disks overlapping (a gap of at least 1e-9 of their radii). ``max_trials``: trials per disk
    before giving up. Returns (x, placed): placed < n when disk ``placed`` found no room."""
    n = radius.size
    x = np.zeros((n, 2))
    if n == 0:
        return x, 0
    np.random.seed(seed)
    reach = hi.max()
    cell = 2.0 * radius.max()
    side = int(2.0 * reach / cell) + 1
    head = np.full(side * side, -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    for i in range(n):
        ri = radius[i]
        a, b = lo[i] * lo[i], hi[i] * hi[i]
        placed = False
        for _ in range(max_trials):
            r = math.sqrt(a + (b - a) * np.random.random())  # uniform in the band's area
            phi = 2.0 * math.pi * np.random.random()
            px, py = r * math.cos(phi), r * math.sin(phi)
            cx = min(int((px + reach) / cell), side - 1)
            cy = min(int((py + reach) / cell), side - 1)
            free = True
            for gy in range(max(cy - 1, 0), min(cy + 2, side)):
                for gx in range(max(cx - 1, 0), min(cx + 2, side)):
                    j = head[gy * side + gx]
                    while j >= 0 and free:
                        dx, dy = px - x[j, 0], py - x[j, 1]
                        reach_ij = (ri + radius[j]) * (1.0 + 1e-9)
                        if dx * dx + dy * dy < reach_ij * reach_ij:
                            free = False
                        j = nxt[j]
                if not free:
                    break
            if free:
                x[i, 0], x[i, 1] = px, py
                k = cy * side + cx
                nxt[i] = head[k]
                head[k] = i
                placed = True
                break
        if not placed:
            return x, i
    return x, n

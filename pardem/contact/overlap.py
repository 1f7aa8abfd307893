"""The overlap guard of the pair loops: an overlap deeper than MAX_OVERLAP of the smaller free
diameter, which the linear law cannot represent (disks would pass through each other), is
flagged by the loops and stops the run (step.py's TOO_DEEP).

Stage: forces (inlined into the loops of forces.py and ring_forces.py).
"""

from __future__ import annotations

import math

import numba as nb

from ..core.jit import INLINE
from .lanes import BATCH, W_AI, W_AJ, W_DX, W_DY

MAX_OVERLAP = 0.25
"""The deepest overlap the contact law is taken to represent, as a fraction of the smaller
diameter of the free disks in the contact (a ring's wall disk does not count: it does not
move, and the rings' small disks are not what passes through). The law models a small
elastic dent: the paper's compressed packings reach ~1 % of d, the densest packing tested ~8 %, a violent head-on impact at the default dt
~20 %. At 25 % the smaller disk's centre is half its radius from the larger one's rim, the
contact chord is wider than that radius and a third disk can touch both centres' overlap
zone; at 50 % (equal disks) each centre lies on the other's rim and the pair is about to
pass through. Deeper overlaps stop a run (forces.contact_forces records them, the step loop
stops every rank) and set the speeds a scene may start with (timestep.check_free_speeds)."""


@nb.njit(**INLINE)
def too_deep(work, ln):
    """Whether lane ln's disks may overlap by more than MAX_OVERLAP of the smaller free
    diameter: centres closer than a_i + a_j - 2 MAX_OVERLAP min(a_i, a_j) (no square root, so
    that the law's loop stays vectorised; note_deep decides with the free disks' diameter)."""
    td_ai = work[W_AI * BATCH + ln]
    td_aj = work[W_AJ * BATCH + ln]
    td_dx = work[W_DX * BATCH + ln]
    td_dy = work[W_DY * BATCH + ln]
    td_lim = td_ai + td_aj - 2.0 * MAX_OVERLAP * min(td_ai, td_aj)
    return td_dx * td_dx + td_dy * td_dy < td_lim * td_lim


@nb.njit(**INLINE)
def note_deep(deep, index, delta, diameter, ring):
    """Keep the deepest overlap delta (m) beyond MAX_OVERLAP of ``diameter`` (m) in
    ForceWork.deep: rare, so the pair loops only flag it (W_ACT = ACT_DEEP) and it is measured here."""
    nd_ratio = delta / diameter
    if nd_ratio > MAX_OVERLAP and nd_ratio > deep[1]:
        deep[0] = index
        deep[1] = nd_ratio
        deep[2] = ring


@nb.njit(**INLINE)
def lane_overlap(work, ln, kind_i, kind_j):
    """(overlap m, smaller diameter of its free disks m) of lane ln: a wall disk (kind != 0)
    cannot move through a free disk, and the rings' 2.5 mm disks would make a compressed
    packing's 8 % of a free diameter look like a third of theirs."""
    lo_ai = work[W_AI * BATCH + ln]
    lo_aj = work[W_AJ * BATCH + ln]
    lo_d = math.sqrt(work[W_DX * BATCH + ln] ** 2 + work[W_DY * BATCH + ln] ** 2)
    lo_fi = lo_ai if kind_i == 0 else math.inf
    lo_fj = lo_aj if kind_j == 0 else math.inf
    return lo_ai + lo_aj - lo_d, 2.0 * min(lo_fi, lo_fj)

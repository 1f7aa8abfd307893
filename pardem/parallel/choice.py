"""Which cut of the annulus a run uses (``cut.Cut``): plain sectors or R rings of P/R sectors,
requested by the user (``pardem run --cut``) or chosen.

``auto`` counts each candidate's ghosts on the free particles' positions (known to every rank at
the start, so every rank makes the same choice) and takes the one whose busiest rank has the
fewest, sectors on a tie (and sectors without counting on up to 3 ranks). A candidate is
allowed only if every domain is at least one interaction reach wide, radially and along its arc
at the ring's inner radius: a narrower domain would take as ghosts particles beyond its own
particles' neighbours, and the ghosts would outnumber the owned particles.
"""

from __future__ import annotations

import math

import numpy as np

from ..input.scene import SceneError
from . import cut as ct

HIST_BINS = 4096  # angular and radial bins of the histograms the cuts are placed on
GHOST_SAMPLE = 200_000  # at most this many positions are used to count ghosts for the choice
# Up to 3 domains, rings are whole rings: a ring's arc (2 pi r, r beyond the inner radius plus a
# share of the gap L) is longer than a sector's two edges across the gap (2 L) in any annulus of
# even density, so sectors are taken without counting (which spares a 2-rank run's first start
# compiling the count).
SECTORS_ALWAYS = 3


def requested_rings(text: str, ranks: int) -> int | None:
    """Rings of a ``--cut`` value: None for ``auto``, 1 for ``sectors``, R for ``RxA``."""
    if text == "auto":
        return None
    if text == "sectors":
        return 1
    parts = text.lower().split("x")
    if len(parts) == 2 and all(p.isdigit() and int(p) > 0 for p in parts):
        rings, per_ring = int(parts[0]), int(parts[1])
        if rings * per_ring == ranks:
            return rings
        raise SceneError(f"--cut {text}: {rings} rings x {per_ring} sectors is "
                         f"{rings * per_ring} domains, but the run has {ranks} MPI ranks")
    raise SceneError(f"--cut {text!r}: expected 'auto', 'sectors' or RINGSxSECTORS (such as "
                     f"2x4, their product the number of ranks)")


def cut_for(x: np.ndarray, ranks: int, rings: int, r_top: float, total=lambda h: h,
            previous: ct.Cut | None = None) -> ct.Cut:
    """``rings`` rings of sectors with about equal counts of the points x [n,2] (m) in every
    domain (``r_top``: m, beyond every point; the radial histogram's range). ``total``: each
    histogram of x summed over the ranks (under MPI, where every rank holds part of the points;
    the same cut on every rank). ``previous``: the cut this one replaces (a re-cut with as many
    rings): each ring keeps its first sector edge, so the sectors do not rotate and only the
    particles near the moved edges migrate."""
    firsts = None if previous is None else previous.edges[:, 0]
    if rings == 1:
        return ct.balanced(total(ct.angle_histogram(x, HIST_BINS)), ranks,
                           None if firsts is None else float(firsts[0]))
    radii = ct.ring_radii(total(ct.radius_histogram(x, r_top, HIST_BINS)), r_top, rings)
    return ct.balanced_rings(radii, total(ct.ring_histograms(x, radii, HIST_BINS)),
                             ranks // rings, firsts)


def narrowest(cut: ct.Cut, inner_radius: float, outer: float) -> float:
    """The smallest width (m) of a domain of ``cut`` in the annulus inner_radius < r < outer:
    radially, and along its ring's inner arc (the ring's sectors are taken as equal, as the
    balance makes them nearly; no arc at r = 0, where a cell without an inner ring has none)."""
    per_ring = cut.edges.shape[1] - 1
    widths = [math.inf]
    for b in range(cut.rings):
        r_in = max(cut.radii[b], inner_radius)
        if cut.rings > 1:
            widths.append(min(cut.radii[b + 1], outer) - r_in)
        if per_ring > 1 and r_in > 0.0:
            widths.append(2.0 * math.pi * r_in / per_ring)
    return min(widths)


def too_many_ranks(size: int, inner_radius: float, reach_width: float) -> str:
    return (f"{size} MPI ranks are too many for this cell: a sector would be "
            f"{2.0 * math.pi * inner_radius / size * 1e3:.2f} mm wide at the inner ring, "
            f"narrower than the interaction reach {reach_width * 1e3:.2f} mm (largest diameter "
            f"+ skin); use at most {int(2.0 * math.pi * inner_radius / reach_width)} ranks")


def choose(x: np.ndarray, ranks: int, requested: str, inner_radius: float, reach: float,
           ghost_width: float) -> tuple[ct.Cut, float]:
    """The cut for ``ranks`` domains of the free particles x [n,2] (m), and its r_top (m,
    for later re-cuts): the ``requested`` one (``requested_rings``) or, for ``auto``, the
    allowed candidate with the fewest ghosts on its busiest rank. SceneError if none is
    allowed."""
    rings = requested_rings(requested, ranks)
    r = np.hypot(x[:, 0], x[:, 1])
    outer = float(r.max()) if r.size else inner_radius + reach
    r_top = outer * (1.0 + 1e-9) + 1e-12
    if rings is not None:
        cut = cut_for(x, ranks, rings, r_top)
        width = narrowest(cut, inner_radius, outer)
        if width < reach:
            raise SceneError(too_many_ranks(ranks, inner_radius, reach) if rings == 1 else
                             f"--cut {requested}: a domain would be {width * 1e3:.2f} mm wide, "
                             f"narrower than the interaction reach {reach * 1e3:.2f} mm (largest "
                             f"diameter + skin); use fewer rings or sectors")
        return cut, r_top
    sample = x[::max(1, -(-x.shape[0] // GHOST_SAMPLE))]
    best = None
    for rings in [k for k in range(1, ranks + 1) if ranks % k == 0]:
        cut = cut_for(x, ranks, rings, r_top)
        if narrowest(cut, inner_radius, outer) < reach:
            continue
        if rings == 1 and ranks <= SECTORS_ALWAYS:
            return cut, r_top
        ghosts = int(ct.ghost_counts(sample, cut.radii, cut.edges, ghost_width).max())
        if best is None or ghosts < best[0]:
            best = (ghosts, cut)
    if best is None:
        raise SceneError(too_many_ranks(ranks, inner_radius, reach))
    return best[1], r_top

"""The pair loop's selection: which listed pairs are close enough to have a force this step
(``select_pairs``), and the zeroing of the history of those that are not (``zero_pairs``).

Stage: forces (called by forces.selected_pairs).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .jit import INLINE, JIT

# Relative padding of select_pairs' distance test, far above the rounding of the law's own
# overlap and approach speed: a pair it leaves out is certainly one the law gives zero.
PAD = 1e-12


@nb.njit(**JIT)
def select_pairs(gx, gv, ga, pi, pj, start, count, h, keep, queue, q):
    """Append to queue[q:] the pairs among [start, start + count) that can have a force:
    closer than a_i + a_j + h (|dv_x| + |dv_y|), with h half a step when the damping window
    is on (a pair farther apart than its own half step of approach gets exactly zero: no
    spring, no damping) and 0 otherwise, padded by PAD for rounding. Returns the new length
    of the queue."""
    one = np.uint64(1)
    for ln in range(count):  # no dependence between pairs: several in flight
        kk = np.uint64(start + ln)
        ii = np.uint64(pi[kk])
        jj = np.uint64(pj[kk])
        dx = gx[ii + ii] - gx[jj + jj]
        dy = gx[ii + ii + one] - gx[jj + jj + one]
        band = h * (abs(gv[ii + ii] - gv[jj + jj]) + abs(gv[ii + ii + one] - gv[jj + jj + one]))
        lim = (ga[ii] + ga[jj] + band) * (1.0 + PAD)
        keep[ln] = 1 if dx * dx + dy * dy < lim * lim else 0
    for ln in range(count):
        queue[q] = start + ln
        q += keep[ln]
    return q


@nb.njit(**INLINE)
def zero_pairs(sxi, rfn, rft, start, stop, n_hist, record):
    """Pairs [start, stop) left with zero history (and recorded forces): the kept ones among
    them get theirs at the scatter."""
    for zq in range(start * n_hist, stop * n_hist):
        sxi[zq] = 0.0
    if record:
        for zq in range(start, stop):
            rfn[zq] = 0.0
        for zq in range(2 * start, 2 * stop):
            rft[zq] = 0.0

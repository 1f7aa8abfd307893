"""The batched pair loop's lanes: the work rows a batch of BATCH pairs is gathered into
(inputs, outputs, history in and out), and ``lane_contact``, the contact law on one lane.

Stage: force kernels (inlined into forces.py's loops). Laying a batch out by rows keeps each
input of 64 pairs in one cache line run, so that the law's loop over lanes vectorises.
"""

from __future__ import annotations

import numba as nb

from ..core.jit import INLINE
from .model import eta_column, history_width, pair_eta, pair_force, rolling_column, spring_column
from .normal import normal_width


BATCH = 64  # pairs per batch of the force loop: its work rows stay in L1
# Rows of the work array (each BATCH lanes): the inputs gathered per pair, the outputs, then
# the history: W_HIST + c in, W_HIST + width + c out.
(W_DX, W_DY, W_AI, W_AJ, W_DVX, W_DVY, W_WI, W_WJ, W_ACT, W_FX, W_FY, W_TI, W_TJ, W_FN, W_FTX,
 W_FTY, W_HIST) = range(17)


@nb.njit(**INLINE)
def work_size(o):
    """The force loop's work rows, then two elements for forces.contact_forces' choice."""
    return (W_HIST + 2 * history_width(o)) * BATCH + 2


@nb.njit(**INLINE)
def lane_contact(work, lane, reach, law, o):
    """pair_force on one lane of the work rows: outputs and updated history written back
    there; returns whether the pair is within reach of a force."""
    lc_hw = history_width(o)
    lc_in = W_HIST * BATCH + lane
    lc_out = (W_HIST + lc_hw) * BATCH + lane
    if o.eta:  # bookkeeping beside the law
        lc_e = eta_column(o) * BATCH
        lc_ex, lc_ey = pair_eta(
            (work[W_DX * BATCH + lane], work[W_DY * BATCH + lane]),
            (work[W_AI * BATCH + lane], work[W_AJ * BATCH + lane]),
            (work[W_DVX * BATCH + lane], work[W_DVY * BATCH + lane]),
            (work[W_WI * BATCH + lane], work[W_WJ * BATCH + lane]),
            (work[lc_in + lc_e], work[lc_in + lc_e + BATCH]), law.dt)
        work[lc_out + lc_e] = lc_ex
        work[lc_out + lc_e + BATCH] = lc_ey
    lc_sp = spring_column(o) * BATCH
    lc_xix = work[lc_in + lc_sp] if o.friction else 0.0
    lc_xiy = work[lc_in + lc_sp + BATCH] if o.friction else 0.0
    lc_xr = work[lc_in + rolling_column(o) * BATCH] if o.rolling else 0.0
    lc_hn = work[lc_in] if normal_width(o) else 0.0
    lc_p, lc_c, lc_h = pair_force(
        (work[W_DX * BATCH + lane], work[W_DY * BATCH + lane]),
        (work[W_AI * BATCH + lane], work[W_AJ * BATCH + lane]),
        (work[W_DVX * BATCH + lane], work[W_DVY * BATCH + lane]),
        (work[W_WI * BATCH + lane], work[W_WJ * BATCH + lane]), (lc_xix, lc_xiy), lc_xr, lc_hn,
        reach, law, o)
    work[W_FX * BATCH + lane] = lc_p.fx
    work[W_FY * BATCH + lane] = lc_p.fy
    work[W_TI * BATCH + lane] = lc_p.tau_i
    work[W_TJ * BATCH + lane] = lc_p.tau_j
    work[W_FN * BATCH + lane] = lc_c.fn
    work[W_FTX * BATCH + lane] = lc_c.ftx
    work[W_FTY * BATCH + lane] = lc_c.fty
    if o.friction:
        work[lc_out + lc_sp] = lc_h.xix
        work[lc_out + lc_sp + BATCH] = lc_h.xiy
    if o.rolling:
        work[lc_out + rolling_column(o) * BATCH] = lc_h.xr
    if normal_width(o):
        work[lc_out] = lc_h.hn
    return lc_p.active

"""The batched pair loop's lanes: the work rows a batch of BATCH pairs is gathered into
(inputs, outputs, history in and out), and ``lane_contact``, the contact law on one lane.

Stage: force kernels (inlined into forces.py's loops). Laying a batch out by rows keeps each
input of 64 pairs in one cache line run, so that the law's loop over lanes vectorises. With
parameters per pair of species (``ContactOptions.pairs``) the gather also copies each pair's
law into rows of its own (``gather_law``), which the law reads at unit stride like its other
inputs (``lane_law``); without, those rows do not exist. With dampings given as restitutions
(damping.py) it also copies both particles' inverse masses (``gather_masses``), from which
``lane_law`` sets the pair's dampings.
"""

from __future__ import annotations

import numba as nb

from ..core.jit import INLINE
from .damping import per_contact, with_damping
from .model import eta_column, history_width, pair_eta, pair_force, rolling_column, spring_column
from .normal import normal_width
from .params import LAW_COLUMNS, LawParams


BATCH = 64  # pairs per batch of the force loop: its work rows stay in L1
# Rows of the work array (each BATCH lanes): the inputs gathered per pair, the outputs, then
# the history: W_HIST + c in, W_HIST + width + c out; then, with pair laws, LAW_COLUMNS rows
# from law_row; then, with dampings given as restitutions, two rows of inverse masses from
# mass_row.
(W_DX, W_DY, W_AI, W_AJ, W_DVX, W_DVY, W_WI, W_WJ, W_ACT, W_FX, W_FY, W_TI, W_TJ, W_FN, W_FTX,
 W_FTY, W_HIST) = range(17)
# Row W_ACT holds each lane's state, a code: not within reach (the scatter skips it), touching,
# or touching too deep (forces.py then measures the overlap). It lives in the float rows: an
# int8 array beside them made LLVM guard the law loop's stores with a run-time alias check
# and a scalar copy of the whole law, 6 % of B's step.
ACT_NONE, ACT_TOUCH, ACT_DEEP = 0.0, 1.0, 2.0


@nb.njit(**INLINE)
def law_row(o):
    """The first row of a lane's pair law (with ``o.pairs``)."""
    return W_HIST + 2 * history_width(o)


@nb.njit(**INLINE)
def mass_row(o):
    """The row of a lane's 1/m_i (then 1/m_j), with ``damping.per_contact(o)``."""
    return law_row(o) + (len(LAW_COLUMNS) if o.pairs else 0)


@nb.njit(**INLINE)
def work_size(o):
    """The force loop's work rows, then two elements for forces.contact_forces' choice."""
    return (mass_row(o) + (2 if per_contact(o) else 0)) * BATCH + 2


@nb.njit(**INLINE)
def gather_masses(work, lane, inv_i, inv_j, o):
    """The two particles' inverse masses (1/kg; 0 for a wall disk) into lane's mass rows."""
    gm_r = mass_row(o) * BATCH + lane
    work[gm_r] = inv_i
    work[gm_r + BATCH] = inv_j


@nb.njit(**INLINE)
def gather_law(work, lane, table, p, q, o):
    """Row (p, q) of the pair laws (Params.pair_law) into lane's law rows."""
    gl_r = law_row(o) * BATCH + lane
    for gl_c in range(len(LAW_COLUMNS)):
        work[gl_r + gl_c * BATCH] = table[p, q, gl_c]


@nb.njit(**INLINE)
def lane_law(work, lane, law, o):
    """The LawParams of lane's pair: its law rows with ``law``'s dt (or ``law`` itself without
    pair laws), with the dampings of its reduced mass where they are given as restitutions."""
    if o.pairs:
        ll_r = law_row(o) * BATCH + lane
        ll_law = LawParams(law.dt, work[ll_r], work[ll_r + BATCH], work[ll_r + 2 * BATCH],
                           work[ll_r + 3 * BATCH], work[ll_r + 4 * BATCH],
                           work[ll_r + 5 * BATCH], work[ll_r + 6 * BATCH],
                           work[ll_r + 7 * BATCH], work[ll_r + 8 * BATCH])
    else:
        ll_law = law
    if not per_contact(o):
        return ll_law
    ll_m = mass_row(o) * BATCH + lane
    return with_damping(ll_law, 1.0 / (work[ll_m] + work[ll_m + BATCH]), o)


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
        reach, lane_law(work, lane, law, o), o)
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

"""Additive ring sums of one sample: the only place where particles and contacts meet rings.

Stage: averaging. Every quantity is first expressed in the local polar frame (e_r, e_phi) at
the particle's centre, then spread over the rings with the particle's weights w (weights.py).
The sums are additive over particles, so every rank sums its owned particles and one
``Allreduce`` gives the totals (``reduce_sums``); time averages are sums over samples. What
each column means, and its unit: ``fields.SUMS``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from pardem.sampling import JIT

from .fields import N_COLUMNS, S
from .weights import extent, ring_weights


@nb.njit(**JIT)
def accumulate(particles, contacts, rings, out):
    """Add one sample's ring sums into out [n_rings, N_COLUMNS].

    particles = (x [n,2], v [n,2], omega [n], radius [n], mass [n]) of the free particles;
    contacts = (start, normal, overlap, force, tangential): the contacts of particle p in rows
    start[p]:start[p+1] of normal [m,2] (unit, from the partner to p), overlap [m], force
    [m,2] (on p), tangential [m,2] (the tangential history t, eta or the spring, in p's
    orientation: Delta = delta n - t); rings = (height, r0, dr, kind): the disk height (m),
    the inner edge of ring 0 (m), the ring width (m) and the weighting (weights.WEIGHTINGS)."""
    x, v, omega, radius, mass = particles
    start, cn, cdelta, cf, cxi = contacts
    height, r0, dr, kind = rings
    n_rings = out.shape[0]
    cap = int(2.0 * extent(radius.max(), kind) / dr) + 3 if radius.size else 3
    ring_of = np.empty(cap, np.int64)
    wts = np.empty(cap)
    q = np.empty(N_COLUMNS)
    for p in range(radius.size):
        rho = math.hypot(x[p, 0], x[p, 1])
        erx, ery = x[p, 0] / rho, x[p, 1] / rho  # e_r; e_phi = (-ery, erx)
        a = radius[p]
        vol = math.pi * a * a * height
        q[:] = 0.0
        q[S.vol] = vol
        q[S.count] = 1.0
        q[S.mass] = mass[p]
        q[S.mom_r] = vol * (v[p, 0] * erx + v[p, 1] * ery)
        q[S.mom_phi] = vol * (-v[p, 0] * ery + v[p, 1] * erx)
        q[S.spin] = vol * omega[p]
        q[S.coord] = vol * (start[p + 1] - start[p])
        q[S.contacts] = start[p + 1] - start[p]
        vr, vphi = v[p, 0] * erx + v[p, 1] * ery, -v[p, 0] * ery + v[p, 1] * erx
        q[S.diam] = 2.0 * a
        q[S.mmom_r] = mass[p] * vr
        q[S.mmom_phi] = mass[p] * vphi
        q[S.kin_rr] = mass[p] * vr * vr
        q[S.kin_rphi] = mass[p] * vr * vphi
        q[S.kin_phiphi] = mass[p] * vphi * vphi
        for c in range(start[p], start[p + 1]):
            nr = cn[c, 0] * erx + cn[c, 1] * ery
            nphi = -cn[c, 0] * ery + cn[c, 1] * erx
            fr = cf[c, 0] * erx + cf[c, 1] * ery
            fphi = -cf[c, 0] * ery + cf[c, 1] * erx
            d = cdelta[c]
            dxr = d * nr - (cxi[c, 0] * erx + cxi[c, 1] * ery)
            dxphi = d * nphi - (-cxi[c, 0] * ery + cxi[c, 1] * erx)
            lever = -(a - 0.5 * d)
            lr, lphi = lever * nr, lever * nphi
            q[S.fabric_rr] += vol * nr * nr
            q[S.fabric_rphi] += vol * nr * nphi
            q[S.fabric_phir] += vol * nphi * nr
            q[S.fabric_phiphi] += vol * nphi * nphi
            q[S.stress_rr] -= fr * lr
            q[S.stress_rphi] -= fr * lphi
            q[S.stress_phir] -= fphi * lr
            q[S.stress_phiphi] -= fphi * lphi
            q[S.deform_rr] -= dxr * lr
            q[S.deform_rphi] -= dxr * lphi
            q[S.deform_phir] -= dxphi * lr
            q[S.deform_phiphi] -= dxphi * lphi
            lxf = lr * fphi - lphi * fr
            lxd = lr * dxphi - lphi * dxr
            q[S.couple_r] -= lxf * lr
            q[S.couple_phi] -= lxf * lphi
            q[S.curv_r] -= lxd * lr
            q[S.curv_phi] -= lxd * lphi
        m = ring_weights(rho, a, r0, dr, n_rings, kind, ring_of, wts)
        for k in range(m):
            w = wts[k]
            row = ring_of[k]
            for col in range(N_COLUMNS):
                out[row, col] += w * q[col]


def reduce_sums(local: np.ndarray, scalars: np.ndarray, reducer=None):
    """Totals over ranks of the ring sums and of a few per-sample scalars: one Allreduce per
    sample (``reducer.sum``: the run's decomposition; None: one process). Returns
    ``(sums, scalars)``."""
    if reducer is None or not reducer.parallel:
        return local, scalars
    total = reducer.sum(np.concatenate([local.ravel(), scalars]))
    return total[:local.size].reshape(local.shape), total[local.size:]

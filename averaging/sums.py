"""Additive ring sums of one sample: the only place where particles and contacts meet rings.

Stage: averaging. Every quantity is first expressed in the local polar frame (e_r, e_phi) at
the particle's centre, then spread over the rings with the particle's weights w (weights.py).
The sums are additive over particles, so every rank sums its owned particles and one
``Allreduce`` gives the totals (``reduce_sums``); time averages are sums over samples.

Columns of a sum array S [n_rings, N_COLUMNS] (V^p = pi a^2 h, h the disk height; l the branch
vector from the particle centre to the contact point, l = -(a - delta/2) n; n the contact
normal pointing from the partner to the particle; f the force on the particle; Delta = delta n
- t the contact displacement, t its tangential history (the paper's eta by default, see
collect.Sample); tensor component ab = first vector's a times second's b, a, b in
{r, phi}; l x f = l_r f_phi - l_phi f_r):

    vol                Sum w V^p                       m^3
    count              Sum w                           (particles)
    mass               Sum w m^p                       kg
    mom_r, mom_phi     Sum w V^p v^p                   m^4/s
    spin               Sum w V^p omega^p               m^3/s
    coord              Sum w V^p C^p  (C^p contacts)   m^3
    fabric_..          Sum w V^p Sum_c n (x) n         m^3
    stress_..          -Sum w Sum_c f (x) l            N m
    deform_..          -Sum w Sum_c Delta (x) l        m^2
    couple_r, _phi     -Sum w Sum_c (l x f) l          N m^2
    curv_r, _phi       -Sum w Sum_c (l x Delta) l      m^3
    contacts           Sum w C^p                       (contacts; C^p / count is the
                                                       number-weighted mean contact number)

The minus signs make compression positive (SPEC §4): with f the force on the particle, -f is
the force the particle exerts on its partner, and -f (x) l is positive for a compressed contact.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .weights import extent, ring_weights

COLUMNS = ("vol", "count", "mass", "mom_r", "mom_phi", "spin", "coord",
           "fabric_rr", "fabric_rphi", "fabric_phir", "fabric_phiphi",
           "stress_rr", "stress_rphi", "stress_phir", "stress_phiphi",
           "deform_rr", "deform_rphi", "deform_phir", "deform_phiphi",
           "couple_r", "couple_phi", "curv_r", "curv_phi", "contacts")
COL = {name: k for k, name in enumerate(COLUMNS)}
N_COLUMNS = len(COLUMNS)
UNITS = {"vol": "m^3", "count": "1", "mass": "kg", "mom_r": "m^4/s", "mom_phi": "m^4/s",
         "spin": "m^3/s", "coord": "m^3", "couple_r": "N m^2", "couple_phi": "N m^2",
         "curv_r": "m^3", "curv_phi": "m^3", "contacts": "1"}
UNITS.update({c: u for prefix, u in (("fabric", "m^3"), ("stress", "N m"), ("deform", "m^2"))
              for c in COLUMNS if c.startswith(prefix)})


@nb.njit(cache=True, error_model="numpy")
def accumulate(x, v, omega, radius, mass, start, cn, cdelta, cf, cxi, height, r0, dr, kind,
               out):
    """Add one sample's ring sums into out [n_rings, N_COLUMNS].

    Particles: x [n,2], v [n,2], omega [n], radius [n], mass [n] (free particles only).
    Contacts of particle p: rows start[p]:start[p+1] of cn [m,2] (unit normal, from the partner
    to p), cdelta [m] (overlap), cf [m,2] (force on p), cxi [m,2] (tangential history t, eta
    or the spring, in p's orientation: Delta = delta n - t)."""
    n_rings = out.shape[0]
    cap = int(2.0 * extent(radius.max(), kind) / dr) + 3 if radius.size else 3
    rings = np.empty(cap, np.int64)
    wts = np.empty(cap)
    q = np.empty(N_COLUMNS)
    for p in range(radius.size):
        rho = math.hypot(x[p, 0], x[p, 1])
        erx, ery = x[p, 0] / rho, x[p, 1] / rho  # e_r; e_phi = (-ery, erx)
        a = radius[p]
        vol = math.pi * a * a * height
        q[:] = 0.0
        q[0] = vol
        q[1] = 1.0
        q[2] = mass[p]
        q[3] = vol * (v[p, 0] * erx + v[p, 1] * ery)
        q[4] = vol * (-v[p, 0] * ery + v[p, 1] * erx)
        q[5] = vol * omega[p]
        q[6] = vol * (start[p + 1] - start[p])
        q[23] = start[p + 1] - start[p]
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
            q[7] += vol * nr * nr
            q[8] += vol * nr * nphi
            q[9] += vol * nphi * nr
            q[10] += vol * nphi * nphi
            q[11] -= fr * lr
            q[12] -= fr * lphi
            q[13] -= fphi * lr
            q[14] -= fphi * lphi
            q[15] -= dxr * lr
            q[16] -= dxr * lphi
            q[17] -= dxphi * lr
            q[18] -= dxphi * lphi
            lxf = lr * fphi - lphi * fr
            lxd = lr * dxphi - lphi * dxr
            q[19] -= lxf * lr
            q[20] -= lxf * lphi
            q[21] -= lxd * lr
            q[22] -= lxd * lphi
        m = ring_weights(rho, a, r0, dr, n_rings, kind, rings, wts)
        for k in range(m):
            w = wts[k]
            row = rings[k]
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

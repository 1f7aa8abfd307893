"""Slot kernels of the contact law (SPEC §3; the paper's eqs. 1.1-1.4): one stateless jitted
function per term, inlined into the composed law of ``model.py``.

Stage: force kernels. A slot that a scene switches off is never called (``model.py`` tests a
compile-time constant), so it costs nothing. Conventions: n points from partner j to particle
i; overlap delta = a_i + a_j - |r_i - r_j| > 0 while touching; v = (vx, vy) is the relative
velocity of the contact point, v_n = v . n = -delta_dot; forces act on i (j gets the opposite).
``law`` is a ``model.LawParams``. Local names carry a per-kernel prefix: a name shared by an
inlined callee and its caller was seen to change results by 1 ulp (see jit.py).
"""

from __future__ import annotations

import math

import numba as nb

from ..core.jit import INLINE


@nb.njit(**INLINE)
def normal_elastic(delta, k_n):
    """Linear normal spring (eq. 1.1): k_n delta (N) while touching, else 0."""
    return k_n * delta if delta > 0.0 else 0.0


@nb.njit(**INLINE)
def normal_viscous(delta, vn, law, window):
    """Viscous normal damping (eq. 1.2) as the term to subtract from f_n: gamma_n v_n (N).

    Without ``window`` it acts in full while delta > 0 (plain velocity Verlet). With it, a pair
    within half a step of touching gets the in-contact fraction of the step: velocity Verlet
    applies each force sample over [t - dt/2, t + dt/2], and the damping jumps at contact entry
    and exit, which otherwise gives e_n an O(dt) error depending on where the contact starts
    between steps (up to 6 % at dt = t_c/50). The fraction is computed in every lane and
    selected, so the batched pair loop's SIMD pass needs no scalar redo: in sheared packings
    about half of the listed pairs that reach contact_law are that close (overlaps ~1e-5 d),
    and redoing them one by one cost ~15 ns per particle-step."""
    if not window:
        return law.gamma_n * vn if delta > 0.0 else 0.0
    nv_half = 0.5 * abs(vn) * law.dt  # overlap change over half a step
    nv_part = 0.5 + 0.5 * delta / nv_half  # inf or nan where nv_half = 0: not selected
    nv_part = nv_part if nv_part > 0.0 else 0.0  # a select, where max() would branch on NaN
    nv_part = nv_part if nv_half > 0.0 else 0.0
    nv_w = 1.0 if delta >= nv_half else nv_part
    return nv_w * law.gamma_n * vn


@nb.njit(**INLINE)
def spring_increment(xix, xiy, nx, ny, vx, vy, vn, dt):
    """A tangential displacement (the Cundall-Strack spring, or the paper's eta) after one step
    (eq. 1.3): rotated into the current tangent plane by projection, plus v_t dt."""
    si_xn = xix * nx + xiy * ny
    return (xix - si_xn * nx + (vx - vn * nx) * dt,
            xiy - si_xn * ny + (vy - vn * ny) * dt)


@nb.njit(**INLINE)
def coulomb_limit(ftx, fty, fn, mu):
    """Coulomb's limit (eq. 1.4): the trial tangential force (N) scaled down to mu |f_n| if it
    exceeds it. Returns ``(ftx, fty, sliding)``. Selects, not branches: every lane of the
    batched pair loop computes the scale (a square root and a division), so that the loop stays
    vectorised however many contacts slide (in steady shear a third of them, each of which a
    deferred cap computed a second time, scalar)."""
    cl_fmax = mu * abs(fn)
    cl_ft2 = ftx * ftx + fty * fty
    cl_sliding = cl_ft2 > cl_fmax * cl_fmax
    cl_cap = cl_fmax / math.sqrt(cl_ft2)  # inf or nan where f_t = 0: not selected
    return (ftx * cl_cap if cl_sliding else ftx), (fty * cl_cap if cl_sliding else fty), cl_sliding


@nb.njit(**INLINE)
def rolling_limit(fr, fn, mu_r):
    """The rolling resistance's Coulomb-type limit: |f_r| <= mu_r |f_n| (N). Returns
    ``(f_r, capped)``; selects, not branches, so that the batched pair loop stays vectorised."""
    rl_max = mu_r * abs(fn)
    rl_capped = abs(fr) > rl_max
    return (math.copysign(rl_max, fr) if rl_capped else fr), rl_capped

"""The contact model of one scene: which slots of ``laws.py`` are on (``ContactOptions``), their
parameters (``LawParams``), the per-contact history they keep, and the composed kernels that the
force loop calls for disk-disk pairs (``pair_force``, on lanes: lanes.py) and disk-ring contacts
(``surface_contact``); also the elastic energy of a contact (the damped spring's analytic
contact time and restitution: damped_spring.py).

Stage: force kernels. Options are compile-time constants (``ContactOptions`` is ``@static``:
its values are part of its numba type), so a slot that is off is compiled out: no branch per
contact and no history column. Slots:

    normal      the elastic normal law, a choice (normal.py: "linear", k_n delta, eq. 1.1,
                by default); always on
    damping     viscous gamma_n delta_dot (eq. 1.2), with the integrator's entry/exit window
    clip        no attractive normal force (off by default, as the analytic solution assumes)
    friction    Cundall-Strack spring xi, f_t = -k_t xi, capped at mu |f_n| (eqs. 1.3-1.4)
    tangential_damping   -gamma_t v_t added to the trial tangential force; at the cap the
                spring keeps k_t xi = -(f_t + gamma_t v_t)
    rolling     rolling spring xi_r (m), incremented by the rolling velocity a' (w_i - w_j),
                f_r = -k_r xi_r capped at mu_r |f_n|; torque a' f_r on i and -a' f_r on j,
                a' = a_i a_j / (a_i + a_j) (a_i against a ring surface)
    eta         bookkeeping: the paper's total tangential displacement eta (eq. 1.3), the
                spring's arithmetic without the cap; no force reads it
    pairs       the parameters (LawParams) per pair of species instead of one set
                (pairs.py); off without [[contact.pair]] tables

History columns per contact, in this order (``history_columns``): the normal law's (its
descriptor's ``history``), the spring (2, with friction), the rolling spring (1, with rolling),
eta (2). A pair that does not touch has all
zero; a new contact starts from zero.

Adding a slot: its kernel in laws.py, its option and columns here, its parameters in
params.py, its keys in scene.py and their checks in keys.py. Adding a choice of the normal slot: normal.py.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb

from ..core.jit import INLINE
from ..core.static import static
from .damping import damping_coefficients
from .laws import coulomb_limit, normal_viscous, rolling_limit, spring_increment
from .normal import (LAWS, law_of, normal_energy, normal_force, normal_width,
                     tangential_stiffness)
from .params import LawParams


@static
class ContactOptions:
    """Which slots are compiled in (hashable; the step loop closes over it)."""

    damping: bool = True
    friction: bool = True
    clip: bool = False
    window: bool = True  # damping weighted at contact entry and exit ([time] integrator)
    tangential_damping: bool = False
    rolling: bool = False
    eta: bool = False
    normal: int = 0  # the normal law's NormalLaw.code (0: linear)
    pairs: bool = False  # parameters per pair of species (contact/pairs.py)
    restitution: bool = False  # gamma_n per contact from [contact] restitution (damping.py)
    tangential_restitution: bool = False  # gamma_t per contact, likewise


def options_for(effects, integrator: str, eta: bool, contact=None,
                pairs: bool = False) -> ContactOptions:
    """The options of a scene's [effects] table, [time] integrator, [contact] table (its
    normal law and whether its dampings are given as restitutions: None, the paper's) and
    whether it gives pair tables."""
    normal = "linear" if contact is None else contact.normal
    e_n = contact is not None and contact.restitution is not None
    e_t = contact is not None and contact.tangential_restitution is not None
    return ContactOptions(
        damping=effects.normal_damping, friction=effects.tangential_friction,
        clip=effects.clip_attractive_normal, window=integrator == "verlet",
        tangential_damping=effects.tangential_damping, rolling=effects.rolling_resistance,
        eta=eta, normal=LAWS[normal].code, pairs=pairs,
        restitution=e_n and effects.normal_damping,
        tangential_restitution=e_t and effects.tangential_damping)


def law_params(contact, dt: float) -> LawParams:
    """LawParams from a scene's [contact] table and the time step (s)."""
    return LawParams(dt, contact.k_n, 0.0, contact.k_t, contact.mu, 0.0, contact.k_r,
                     contact.mu_r)._replace(**damping_coefficients(contact),
                                            **law_of(contact).coefficients(contact))


def history_columns(o: ContactOptions) -> tuple[str, ...]:
    """Names of the history columns, in storage order."""
    normal = next(law.history for law in LAWS.values() if law.code == o.normal)
    return (normal + (("spring_x", "spring_y") if o.friction else ())
            + (("rolling",) if o.rolling else ()) + (("eta_x", "eta_y") if o.eta else ()))


@nb.njit(**INLINE)
def history_width(o):
    return normal_width(o) + (2 if o.friction else 0) + (1 if o.rolling else 0) + (
        2 if o.eta else 0)


@nb.njit(**INLINE)
def spring_column(o):
    return normal_width(o)


@nb.njit(**INLINE)
def rolling_column(o):
    return normal_width(o) + (2 if o.friction else 0)


@nb.njit(**INLINE)
def eta_column(o):
    return normal_width(o) + (2 if o.friction else 0) + (1 if o.rolling else 0)


# ----------------------------------------------------------------- the composed law

class ContactForce(NamedTuple):
    """What contact_law gives on i: the normal force fn (N, along n), the tangential force
    (ftx, fty) (N), the rolling resistance fr (N; a' fr is its torque on i) and whether the
    contact slides (held at the Coulomb cap)."""

    fn: float
    ftx: float
    fty: float
    fr: float
    sliding: bool


class History(NamedTuple):
    """A contact's history: tangential spring (xix, xiy), rolling spring xr (m), normal.py's hn."""

    xix: float
    xiy: float
    xr: float
    hn: float


class PairForce(NamedTuple):
    """pair_force's ``active`` (within reach of a force), force (fx, fy) on i (N; j gets -f)
    and torques tau_i, tau_j (N m)."""

    active: bool
    fx: float
    fy: float
    tau_i: float
    tau_j: float


@nb.njit(**INLINE)
def contact_law(n, delta, v, spring, xr, hn, a_red, w, law, o):
    """``-> (ContactForce, History)`` of a contact with unit normal n = (nx, ny), overlap delta
    (m; <= 0: within half a step of touching, which gets only its share of the damping) and
    contact-point velocity v = (vx, vy) (m/s). ``spring`` = (xix, xiy), xr and hn: its History
    before this step. a_red (m): the reduced radius a'; w = (w_i, w_j): the spins."""
    cl_nx, cl_ny = n
    cl_vx, cl_vy = v
    cl_xix, cl_xiy = spring
    cl_xr = xr
    cl_vn = cl_vx * cl_nx + cl_vy * cl_ny  # = -delta_dot
    cl_fn, cl_hn = normal_force(delta, a_red, hn, law, o)
    if o.damping:
        cl_fn -= normal_viscous(delta, cl_vn, law, o.window)
    if o.clip:
        cl_fn = max(cl_fn, 0.0)
    if not (o.friction or o.rolling):
        return ContactForce(cl_fn, 0.0, 0.0, 0.0, False), History(cl_xix, cl_xiy, cl_xr, cl_hn)
    if delta <= 0.0:  # within reach of a contact, not touching: no springs
        return ContactForce(cl_fn, 0.0, 0.0, 0.0, False), History(0.0, 0.0, 0.0, cl_hn)
    cl_ftx, cl_fty, cl_fr, cl_sliding = 0.0, 0.0, 0.0, False
    if o.friction:
        cl_kt = tangential_stiffness(delta, a_red, law, o)
        cl_xix, cl_xiy = spring_increment(cl_xix, cl_xiy, cl_nx, cl_ny, cl_vx, cl_vy, cl_vn, law.dt)
        cl_ftx = -cl_kt * cl_xix
        cl_fty = -cl_kt * cl_xiy
        if o.tangential_damping:
            cl_vtx = cl_vx - cl_vn * cl_nx
            cl_vty = cl_vy - cl_vn * cl_ny
            cl_ftx -= law.gamma_t * cl_vtx
            cl_fty -= law.gamma_t * cl_vty
        cl_ftx, cl_fty, cl_sliding = coulomb_limit(cl_ftx, cl_fty, cl_fn, law.mu)
        # sliding: the spring holds what the cap allows (selects, as in coulomb_limit)
        if o.tangential_damping:
            cl_sx = -(cl_ftx + law.gamma_t * cl_vtx) / cl_kt
            cl_sy = -(cl_fty + law.gamma_t * cl_vty) / cl_kt
        else:
            cl_sx = -cl_ftx / cl_kt
            cl_sy = -cl_fty / cl_kt
        cl_xix = cl_sx if cl_sliding else cl_xix
        cl_xiy = cl_sy if cl_sliding else cl_xiy
    if o.rolling:
        cl_wi, cl_wj = w
        cl_xr = cl_xr + a_red * (cl_wi - cl_wj) * law.dt
        cl_fr, cl_rcap = rolling_limit(-law.k_r * cl_xr, cl_fn, law.mu_r)
        cl_xr = -cl_fr / law.k_r if cl_rcap else cl_xr
    return (ContactForce(cl_fn, cl_ftx, cl_fty, cl_fr, cl_sliding),
            History(cl_xix, cl_xiy, cl_xr, cl_hn))


@nb.njit(**INLINE)
def pair_force(d, a, dv, w, spring, xr, hn, reach, law, o):
    """``-> (PairForce, ContactForce, History)`` of a disk-disk contact (zeros beyond reach).
    d = r_i - r_j, a = (a_i, a_j) radii, dv = v_i - v_j, w = (w_i, w_j) spins; spring, xr and
    hn: the history (contact_law); reach (m) bounds how far any overlap can change in half a
    step (pairs that close get their share of damping). Swapping i and j negates the force bit
    for bit (every operation is odd in the swap)."""
    pf_dx, pf_dy = d
    pf_ai, pf_aj = a
    pf_dvx, pf_dvy = dv
    pf_wi, pf_wj = w
    pf_r2 = pf_dx * pf_dx + pf_dy * pf_dy
    pf_rs = pf_ai + pf_aj
    pf_lim = pf_rs + reach if o.damping and o.window else pf_rs
    if pf_r2 >= pf_lim * pf_lim:
        return (PairForce(False, 0.0, 0.0, 0.0, 0.0), ContactForce(0.0, 0.0, 0.0, 0.0, False),
                History(0.0, 0.0, 0.0, 0.0))
    pf_dist = math.sqrt(pf_r2)
    pf_inv = 1.0 / pf_dist
    pf_nx = pf_dx * pf_inv
    pf_ny = pf_dy * pf_inv
    pf_delta = pf_rs - pf_dist
    pf_s = pf_ai * pf_wi + pf_aj * pf_wj
    pf_ared = pf_ai * pf_aj / pf_rs  # the rolling spring's a' and Hertz's R*
    # v_ij = dv - s (z x n), with z x n = (-ny, nx)
    pf_v = (pf_dvx + pf_s * pf_ny, pf_dvy - pf_s * pf_nx)
    pf_c, pf_h = contact_law((pf_nx, pf_ny), pf_delta, pf_v, spring, xr, hn, pf_ared, w, law, o)
    # torque of f_t about each centre, lever (a - delta/2) along -n for i and +n for j
    pf_nxft = pf_nx * pf_c.fty - pf_ny * pf_c.ftx
    pf_ti = -(pf_ai - 0.5 * pf_delta) * pf_nxft
    pf_tj = -(pf_aj - 0.5 * pf_delta) * pf_nxft
    if o.rolling:
        pf_ti += pf_ared * pf_c.fr
        pf_tj -= pf_ared * pf_c.fr
    return (PairForce(True, pf_c.fn * pf_nx + pf_c.ftx, pf_c.fn * pf_ny + pf_c.fty, pf_ti,
                      pf_tj), pf_c, pf_h)


@nb.njit(**INLINE)
def pair_eta(d, a, dv, w, eta, dt):
    """The paper's eta (eq. 1.3) of a disk-disk pair after one step, with pair_force's geometry
    (arguments as there; eta = (ex, ey) before the step): the spring's arithmetic without the
    cap, so it equals the spring bit for bit until the contact first slides; (0, 0) unless the
    disks overlap (a new contact starts from zero). Selects, not branches, so that the batched
    pair loop stays vectorised."""
    pd_dx, pd_dy = d
    pd_ai, pd_aj = a
    pd_wi, pd_wj = w
    pd_dist = math.sqrt(pd_dx * pd_dx + pd_dy * pd_dy)
    pd_inv = 1.0 / pd_dist
    pd_nx = pd_dx * pd_inv
    pd_ny = pd_dy * pd_inv
    pd_s = pd_ai * pd_wi + pd_aj * pd_wj
    pd_vx = dv[0] + pd_s * pd_ny
    pd_vy = dv[1] - pd_s * pd_nx
    pd_vn = pd_vx * pd_nx + pd_vy * pd_ny
    pd_ex, pd_ey = spring_increment(eta[0], eta[1], pd_nx, pd_ny, pd_vx, pd_vy, pd_vn, dt)
    pd_on = pd_ai + pd_aj - pd_dist > 0.0
    return (pd_ex if pd_on else 0.0), (pd_ey if pd_on else 0.0)


# ----------------------------------------------------------------- contacts with a surface

@nb.njit(**INLINE)
def surface_contact(n, delta, a, v, w, hist, i, law, o):
    """A free disk (radius a) against an infinitely massive surface (a ring): unit normal
    n = (nx, ny) from the surface to the disk, overlap delta, contact-point velocity
    v = (vx, vy) relative to the surface, w = (disk spin, surface spin). Reads and updates
    row i of ``hist`` (the disk's surface-contact history, ``history_columns``); returns
    ``(fn, ftx, fty, torque)`` on the disk. Reduced radius a' = a (the surface's curvature
    is ignored)."""
    sc_nx, sc_ny = n
    sc_vx, sc_vy = v
    sc_sp = spring_column(o)
    sc_xix = hist[i, sc_sp] if o.friction else 0.0
    sc_xiy = hist[i, sc_sp + 1] if o.friction else 0.0
    sc_xr = hist[i, rolling_column(o)] if o.rolling else 0.0
    sc_hn = hist[i, 0] if normal_width(o) else 0.0
    sc_f, sc_h = contact_law(n, delta, v, (sc_xix, sc_xiy), sc_xr, sc_hn, a, w, law, o)
    if normal_width(o):
        hist[i, 0] = sc_h.hn
    if o.friction:
        hist[i, sc_sp] = sc_h.xix
        hist[i, sc_sp + 1] = sc_h.xiy
    if o.rolling:
        hist[i, rolling_column(o)] = sc_h.xr
    if o.eta:
        sc_c = eta_column(o)
        sc_ex, sc_ey = 0.0, 0.0
        if delta > 0.0:
            sc_vn = sc_vx * sc_nx + sc_vy * sc_ny
            sc_ex, sc_ey = spring_increment(hist[i, sc_c], hist[i, sc_c + 1], sc_nx, sc_ny,
                                            sc_vx, sc_vy, sc_vn, law.dt)
        hist[i, sc_c] = sc_ex
        hist[i, sc_c + 1] = sc_ey
    sc_torque = -(a - 0.5 * delta) * (sc_nx * sc_f.fty - sc_ny * sc_f.ftx)
    if o.rolling:
        sc_torque += a * sc_f.fr
    return sc_f.fn, sc_f.ftx, sc_f.fty, sc_torque


@nb.njit(**INLINE)
def elastic_energy(delta, a_red, hist, k, law, o):
    """Energy (J) stored in a contact with overlap delta, reduced radius a_red (m) and history
    row k of ``hist``: the normal law, the tangential spring and the rolling spring."""
    ee_hn = hist[k, 0] if normal_width(o) else 0.0
    ee_sum = normal_energy(delta, a_red, ee_hn, law, o) if delta > 0.0 else 0.0
    if delta > 0.0 and o.friction:
        ee_sp = spring_column(o)
        ee_sum += 0.5 * tangential_stiffness(delta, a_red, law, o) * (
            hist[k, ee_sp] ** 2 + hist[k, ee_sp + 1] ** 2)
    if delta > 0.0 and o.rolling:
        ee_sum += 0.5 * law.k_r * hist[k, rolling_column(o)] ** 2
    return ee_sum

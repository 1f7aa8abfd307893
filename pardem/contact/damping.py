"""Damping given as restitutions: each contact's dashpots from its reduced mass.

Stage: set-up (``damping_coefficients``, ``mixing_rules``, ``tangential_gamma``) and force
kernels (``with_damping``, inlined). ``[contact] restitution = e_n`` and ``tangential_restitution = e_t`` make the damping
a property of the material instead of the pair's masses: a contact of reduced mass m_red gets

    gamma_n = beta(e_n) sqrt(k_n m_red)        (the normal spring's oscillator, mass m_red)
    gamma_t = beta(e_t) sqrt(k_t m_red / 3)    (the sticking contact's oscillator)

with beta(e) = 2L/sqrt(pi^2 + L^2), L = -ln e (damped_spring.restitution_beta). A sticking
contact between two turning disks (I = m a^2/2) moves its contact point against an effective
mass 1/(1/m_i + 1/m_j + a_i^2/I_i + a_j^2/I_j) = m_red/3, so e_t is the ratio of the tangential
contact-point speeds at two successive zero crossings of the spring, whatever the masses. A
sliding contact has no constant e_t (the Coulomb cap takes over). A ring or a wall disk is
infinitely massive: m_red is the free disk's mass.

Like LAMMPS's damping sub-models, the choice defines what the coefficient stored in the law
means: with a restitution (``ContactOptions.restitution``, ``tangential_restitution``) the
LawParams column gamma_n (gamma_t) holds beta, and ``with_damping`` turns it into the
contact's gamma in kg/s; a pair without a table mixes the betas by the mean of the
logarithmic decrements (``mixing_rules``). Without, the column is gamma in kg/s and
``with_damping`` returns the law itself: nothing of this is compiled in.
"""

from __future__ import annotations

import math

import numba as nb

from ..core.jit import INLINE
from .damped_spring import beta_decrement, decrement_beta, restitution_beta
from .params import LawParams


def damping_coefficients(contact) -> dict:
    """The LawParams columns gamma_n and gamma_t of a [contact] table: gamma (kg/s), or the
    beta of its restitution where one is given."""
    e_n, e_t = contact.restitution, contact.tangential_restitution
    return {"gamma_n": contact.gamma_n if e_n is None else restitution_beta(e_n),
            "gamma_t": contact.gamma_t if e_t is None else restitution_beta(e_t)}


def tangential_gamma(contact, k_t: float, m_red: float) -> float:
    """gamma_t (kg/s) of a contact of tangential stiffness k_t (N/m) and reduced mass m_red
    (kg) under the [contact] table ``contact``: its gamma_t, or the one its e_t gives."""
    e_t = contact.tangential_restitution
    return contact.gamma_t if e_t is None else restitution_beta(e_t) * math.sqrt(k_t * m_red / 3)


def restitutions(a: float, b: float) -> float:
    """The beta of the restitution sqrt(e_a e_b) of two betas: the mean of their decrements
    -ln e."""
    if a == b:
        return a
    return decrement_beta(0.5 * (beta_decrement(a) + beta_decrement(b)))


def mixing_rules(contact, rules: dict) -> dict:
    """``rules`` (contact/pairs.py's MIXING) with the damping columns that hold a restitution's
    beta in a scene whose [contact] table is ``contact`` mixed as restitutions."""
    return {**rules, **{k: restitutions for k, e in (("gamma_n", contact.restitution),
                                                       ("gamma_t", contact.tangential_restitution))
                        if e is not None}}


@nb.njit(**INLINE)
def per_contact(o):
    """Whether a contact's dampings depend on its masses (the lanes then gather 1/m)."""
    return o.restitution or o.tangential_restitution


@nb.njit(**INLINE)
def with_damping(law, m_red, o):
    """``law`` with the dampings (kg/s) of a contact of reduced mass m_red (kg) where they are
    given as restitutions (its columns then hold beta), else ``law`` itself."""
    if not per_contact(o):
        return law
    wd_gn = law.gamma_n * math.sqrt(law.k_n * m_red) if o.restitution else law.gamma_n
    wd_gt = (law.gamma_t * math.sqrt(law.k_t * m_red / 3.0) if o.tangential_restitution
             else law.gamma_t)
    return LawParams(law.dt, law.k_n, wd_gn, law.k_t, law.mu, wd_gt, law.k_r, law.mu_r,
                     law.k_unload, law.k_adhesion)

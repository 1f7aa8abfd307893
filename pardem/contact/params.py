"""The parameters of a contact law as the kernels read them (``LawParams``).

Stage: set-up (model.law_params fills them from a [contact] table, pairs.py per pair of
partners) and force kernels (passed by value; every field is a float).
"""

from __future__ import annotations

from typing import NamedTuple


class LawParams(NamedTuple):
    """Parameters of the law (SI): dt (s), k_n (N/m), gamma_n (kg/s), k_t (N/m), mu,
    gamma_t (kg/s), k_r (N/m), mu_r, then the normal laws' further coefficients. The meaning
    of k_n and k_t is the normal law's (normal.NormalLaw.coefficients); gamma_n and gamma_t
    hold a restitution's beta where the damping is given as one (damping.py)."""

    dt: float
    k_n: float
    gamma_n: float
    k_t: float
    mu: float
    gamma_t: float = 0.0
    k_r: float = 0.0
    mu_r: float = 0.0
    k_unload: float = 0.0
    k_adhesion: float = 0.0


LAW_COLUMNS = LawParams._fields[1:]
"""What may differ from pair to pair: every parameter but dt (contact/pairs.py)."""

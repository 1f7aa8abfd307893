"""Hertz's normal law with Mindlin's tangential stiffness (``[contact] normal = "hertz"``).

The disks are taken as spheres of their diameters lying in a monolayer: two of them touching
with overlap delta push apart with F_n = (4/3) E* sqrt(R*) delta^(3/2), E* = E/(2(1 - nu^2))
for one material (``youngs_modulus`` E in Pa, ``poisson_ratio`` nu), R* = a_i a_j/(a_i + a_j)
(a against a ring surface, which is flat). The tangential spring's stiffness grows with the
contact radius sqrt(R* delta) as Mindlin's, k_t = 8 G* sqrt(R* delta), G* = G/(2(2 - nu)),
G = E/(2(1 + nu)); its displacement history is kept as for the linear law (LAMMPS's
``mindlin`` without rescaling), so a sticking spring's force follows the stiffness.

The time step, the impact-speed checks and the averaging's k'_n use the law's stiffness at
REFERENCE_OVERLAP of the largest free disk's diameter (R* of two such disks): the tangent
dF/d delta for the contact time and the stable step, the secant F/delta (softer, so deeper)
for how far an impact goes. A scene whose contacts go deeper than the reference overlap
stiffens beyond it and should set [time] dt_per_contact higher.
"""

from __future__ import annotations

import math

import numba as nb

from ..core.jit import INLINE
from .slot import NormalLaw

REFERENCE_OVERLAP = 0.05  # of the diameter: the deepest overlap the auto step is made for


def _moduli(c) -> tuple[float, float]:
    """(E*, G*) in Pa of one material."""
    e, nu = c.youngs_modulus, c.poisson_ratio
    return e / (2.0 * (1.0 - nu * nu)), e / (2.0 * (1.0 + nu)) / (2.0 * (2.0 - nu))


def _coefficients(c) -> dict:
    e_star, g_star = _moduli(c)
    return {"k_n": 4.0 / 3.0 * e_star, "k_t": 8.0 * g_star}


def _stiffness(c, d: float) -> tuple[float, float, float]:
    e_star, g_star = _moduli(c)
    contact_radius = math.sqrt(d / 4.0 * REFERENCE_OVERLAP * d)  # sqrt(R* delta), R* = d/4
    tangent = 2.0 * e_star * contact_radius
    return 2.0 / 3.0 * tangent, tangent, 8.0 * g_star * contact_radius


HERTZ = NormalLaw(
    "hertz", 1, ("youngs_modulus", "poisson_ratio"), ("youngs_modulus", "poisson_ratio"), (),
    _coefficients, _stiffness, tangential=True,
    summary="Hertz's (4/3) E* sqrt(R*) delta^(3/2) with Mindlin's tangential stiffness")


@nb.njit(**INLINE)
def hertz_force(delta, a_red, law):
    """(4/3) E* sqrt(R*) delta^(3/2) (N) while touching, else 0 (law.k_n = (4/3) E*)."""
    hz_d = delta if delta > 0.0 else 0.0
    return law.k_n * hz_d * math.sqrt(a_red * hz_d)


@nb.njit(**INLINE)
def hertz_tangential(delta, a_red, law):
    """Mindlin's 8 G* sqrt(R* delta) (N/m) (law.k_t = 8 G*)."""
    ht_d = delta if delta > 0.0 else 0.0
    return law.k_t * math.sqrt(a_red * ht_d)


@nb.njit(**INLINE)
def hertz_energy(delta, a_red, law):
    """(8/15) E* sqrt(R*) delta^(5/2) (J), the work of hertz_force from 0 to delta."""
    return 0.4 * hertz_force(delta, a_red, law) * delta

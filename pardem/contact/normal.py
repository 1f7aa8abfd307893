"""The normal slot of the contact model: which elastic law pushes two touching disks apart.

Stage: input (the descriptors) and force kernels (the dispatch). Each choice is one
``NormalLaw`` descriptor registered in ``LAWS`` under its scene name (``[contact] normal``);
its compiled kernels live in its own module. The descriptor declares everything the rest of
pardem needs to know about the law, so that no other module names one:

    keys         its [contact] parameters (declared with units and rules in scene.Contact);
                 a key of another law is refused, naming the law
    required     the keys a scene must give when it picks the law
    history      per-contact history columns the law keeps (before the tangential spring's)
    coefficients the LawParams fields the kernels read, from the [contact] table
    stiffness    (k_load, k_elastic, k_t) N/m at the reference overlap of a disk of diameter
                 d: the linear stiffnesses the time step, the impact-speed checks and the
                 averaging's normalisation k'_n = k_elastic/h use (the linear law's k_n, k_n,
                 k_t exactly)
    tangential   whether the tangential spring's stiffness scales with the contact radius
                 sqrt(R* delta) (Mindlin: k_t is then a modulus, N/m^2)
    restitution  whether [contact] restitution may give the damping: a closed form of the
                 restitution of the law with viscous damping (the linear spring's)

The compiled side is three dispatch kernels below (force, tangential stiffness, stored energy),
each a chain of compile-time tests on ``ContactOptions.normal`` (the law's ``code``): the
chosen law is inlined, the others are compiled out. Adding a law: its module (descriptor and
kernels), its entry in ``LAWS`` and its branch in each kernel here, its keys in scene.Contact
(docs/extending.md walks through the Luding law).
"""

from __future__ import annotations

import numba as nb

from ..core.jit import INLINE
from .hertz import HERTZ, hertz_energy, hertz_force, hertz_tangential
from .laws import normal_elastic
from .luding import LUDING, luding_energy, luding_force
from .slot import NormalLaw


LINEAR = NormalLaw(
    "linear", 0, ("k_n",), (), (), lambda c: {"k_n": c.k_n, "k_t": c.k_t},
    lambda c, d: (c.k_n, c.k_n, c.k_t), restitution=True,
    summary="the paper's linear spring k_n delta (eq. 1.1)")

LAWS: dict[str, NormalLaw] = {law.name: law for law in (LINEAR, HERTZ, LUDING)}
HERTZ_CODE = HERTZ.code  # the kernels compare ints (numba does not read a descriptor)
LUDING_CODE = LUDING.code


def law_of(contact) -> NormalLaw:
    """The descriptor a [contact] table (scene.Contact) picks."""
    return LAWS[contact.normal]


# ----------------------------------------------------------------- compiled dispatch

@nb.njit(**INLINE)
def normal_width(o):
    """History columns of the normal law (they come first in a contact's history row)."""
    return 1 if o.normal == LUDING_CODE else 0


@nb.njit(**INLINE)
def normal_force(delta, a_red, hist, law, o):
    """``-> (f_n (N), hist)``: the elastic (or hysteretic) normal force at overlap delta (m;
    0 unless delta > 0) with reduced radius a_red (m), and the law's history after it."""
    if o.normal == HERTZ_CODE:
        return hertz_force(delta, a_red, law), hist
    if o.normal == LUDING_CODE:
        return luding_force(delta, hist, law)
    return normal_elastic(delta, law.k_n), hist


@nb.njit(**INLINE)
def tangential_stiffness(delta, a_red, law, o):
    """The tangential spring's stiffness (N/m) at overlap delta: k_t, or with a law whose
    ``tangential`` is set, k_t sqrt(a_red delta)."""
    if o.normal == HERTZ_CODE:
        return hertz_tangential(delta, a_red, law)
    return law.k_t


@nb.njit(**INLINE)
def normal_energy(delta, a_red, hist, law, o):
    """Energy (J) the normal law stores at overlap delta > 0."""
    if o.normal == HERTZ_CODE:
        return hertz_energy(delta, a_red, law)
    if o.normal == LUDING_CODE:
        return luding_energy(delta, hist, law)
    return 0.5 * law.k_n * delta * delta

"""Luding's hysteretic, adhesive normal law (``[contact] normal = "luding"``; S. Luding,
Granular Matter 10, 235 (2008), without its plasticity depth: k_2 is constant).

A contact loads along k_1 (``k_n``), unloads and reloads along k_2 (``k_unload`` >= k_1)
from the deepest overlap it reached, delta_max, and may pull (adhesion) down to -k_c delta
(``k_adhesion`` >= 0):

    f = k_1 delta                  while delta >= delta_max (loading; delta_max follows delta)
    f = k_2 (delta - delta_0)      below it, delta_0 = (1 - k_1/k_2) delta_max
    f = -k_c delta                 where k_2 (delta - delta_0) would pull harder; delta_max
                                   moves with delta there, so reloading leaves this branch
                                   along k_2

delta_max is the law's history column (per contact, 0 for a new one). Without damping a
head-on collision returns e^2 = a - (1 - a)^2 (k_2/k_1) k_c/(k_2 + k_c), a = k_1/k_2: the
work of unloading along k_2 less that of the tension branches. The tangential spring keeps
the linear law's k_t. The time step and the averaging's k'_n use k_2 (the stiffer, elastic
branch); an impact's depth, k_1.
"""

from __future__ import annotations

import numba as nb

from ..core.jit import INLINE
from ..input.values import fail
from .slot import NormalLaw


def _check(c: dict) -> None:
    if not c["k_unload"] >= c["k_n"]:
        raise fail("[contact]", "k_unload", c["k_unload"], f"must be >= k_n = {c['k_n']!r} "
                   "(unloading is stiffer than loading in Luding's law)", "N/m")


LUDING = NormalLaw(
    "luding", 2, ("k_n", "k_unload", "k_adhesion"), ("k_unload",), ("delta_max",),
    lambda c: {"k_n": c.k_n, "k_t": c.k_t, "k_unload": c.k_unload,
               "k_adhesion": c.k_adhesion},
    lambda c, d: (c.k_n, c.k_unload, c.k_t), check=_check,
    summary="Luding's hysteretic adhesive law: load k_n, unload k_unload, pull -k_adhesion delta")


@nb.njit(**INLINE)
def luding_force(delta, delta_max, law):
    """``-> (f (N), delta_max)`` at overlap delta with the deepest overlap so far delta_max
    (law.k_n = k_1, law.k_unload = k_2, law.k_adhesion = k_c); (0, 0) once apart."""
    if not delta > 0.0:
        return 0.0, 0.0
    if delta >= delta_max:
        return law.k_n * delta, delta
    ld_f = law.k_unload * (delta - (1.0 - law.k_n / law.k_unload) * delta_max)
    ld_floor = -law.k_adhesion * delta
    if ld_f < ld_floor:  # k_2 > k_1 here: with k_2 = k_1, f = k_1 delta > -k_c delta
        return ld_floor, delta * (law.k_unload + law.k_adhesion) / (law.k_unload - law.k_n)
    return ld_f, delta_max


@nb.njit(**INLINE)
def luding_energy(delta, delta_max, law):
    """f^2/(2 k_2) (J): what unloading along k_2 gives back (or, pulling, what it stores)."""
    le_f = luding_force(delta, delta_max, law)[0]
    return 0.5 * le_f * le_f / law.k_unload

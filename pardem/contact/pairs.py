"""Contact parameters per pair of species: the law of each pair of partners (two species, or a
species and a ring), the partner index of each particle, and the table the force kernels read.

Stage: set-up (``pair_table``, ``pair_contacts``: simulation.py, scales.py, stability.py) and
force kernels (``pair_law``). The scene's ``[[contact.pair]]`` tables (input/pair_table.py) give
some of the [contact] keys for one pair of partners.

A pair without a table mixes its partners' own laws. A species' own law is its table with
itself (species = [a, a]) over [contact], or [contact] without one; a ring's own law is
[contact]. A pair table's keys left out take the [contact] value, not the mix. The mixing
rule, per parameter (``MIXING``):

    stiffnesses  k_n, k_t, k_r, k_unload, k_adhesion: the harmonic mean 2 k_a k_b/(k_a + k_b),
                 two half-contacts of stiffness 2 k_a and 2 k_b in series. For Hertz
                 (k_n = (4/3) E*, k_t = 8 G*) this is the two-material formula
                 1/E* = (1 - nu_a^2)/E_a + (1 - nu_b^2)/E_b, and Mindlin's for G*.
    dampings     gamma_n, gamma_t: the harmonic mean too, the half-contacts' dashpots in series
    friction     mu, mu_r: the geometric mean sqrt(mu_a mu_b) (LAMMPS's rule; a friction
                 coefficient belongs to the pair of surfaces, so give the pair a table where
                 it is known)
    restitution  e_n, e_t given as [contact] restitution, tangential_restitution: the
                 geometric mean sqrt(e_a e_b), the mean of the two logarithmic decrements (a
                 convention, as for friction; damping.py)

Each rule gives a pair of one species its own law exactly (mix(x, x) = x), and a scene
without pair tables the paper's single law, bit for bit.

Partners are numbered: the scene's species 0 .. S-1 (couette: in [[species]] order; free:
the particles' ``species`` numbers), then the inner ring S and the outer ring S+1 (their wall
disks carry these numbers, and their flat surfaces use them). ``pair_table`` is a float array
[S+2, S+2, len(LAW_COLUMNS)]: row (p, q) holds the LawParams of that pair without dt (the
mix where no table is given), symmetric. It reaches the kernels as
``state.Params.pair_law``; the force loop copies each listed pair's row into its lanes
(lanes.gather_law) and the law reads them there (lanes.lane_law); a ring contact reads its
row directly (``pair_law``). All of this is under ``ContactOptions.pairs``, a compile-time
constant that is off unless the scene gives a pair table: without one the kernels are those
of a single law, and Params carries an empty table.
"""

from __future__ import annotations

import dataclasses

import numba as nb
import numpy as np

from ..core.jit import INLINE
from .damping import mixing_rules
from .model import law_params
from .params import LAW_COLUMNS, LawParams


def harmonic(a: float, b: float) -> float:
    """2ab/(a + b): springs (and dashpots) of two half-contacts in series; 0 if either is."""
    return a if a == b else (2.0 * a * b / (a + b) if a > 0.0 and b > 0.0 else 0.0)


def geometric(a: float, b: float) -> float:
    """sqrt(ab), the friction coefficients' rule."""
    return a if a == b else float(np.sqrt(a * b))


MIXING = {"k_n": harmonic, "gamma_n": harmonic, "k_t": harmonic, "mu": geometric,
          "gamma_t": harmonic, "k_r": harmonic, "mu_r": geometric, "k_unload": harmonic,
          "k_adhesion": harmonic}
"""The rule per LawParams column of a pair without a table (see above); a damping given as
a restitution mixes as one (damping.mixing_rules)."""
assert set(MIXING) == set(LAW_COLUMNS)

BOUNDARIES = ("inner_ring", "outer_ring")
"""Partner names of the rings (their wall disks and flat surfaces) in a couette scene."""


def species_count(scene) -> int:
    """S: the number of species (couette: [[species]] tables; free: 1 + the largest species
    number of the particles)."""
    if scene.particles is not None:
        return int(scene.particles.species.max()) + 1
    return len(scene.species)


def partner_names(scene) -> tuple:
    """What a pair table may name, in partner order: the species (couette: their names, then
    BOUNDARIES; free: the species numbers)."""
    if scene is None or scene.particles is not None:
        return tuple(range(species_count(scene)))
    return tuple(s.name for s in scene.species) + BOUNDARIES


def pair_contacts(scene) -> list[tuple[tuple[int, int], object]]:
    """((p, q), the [contact] table of that pair: scene.Contact with the pair's keys) for every
    pair table, partners numbered as above (p <= q)."""
    names = partner_names(scene)
    return [((names.index(p.species[0]), names.index(p.species[1])),
             dataclasses.replace(scene.contact, **dict(p.values))) for p in scene.pairs]


def own_contacts(scene) -> list:
    """The own law (a [contact] table) of each partner: its table with itself, else [contact]."""
    given = dict(pair_contacts(scene))
    n = species_count(scene) + len(BOUNDARIES)
    return [given.get((p, p), scene.contact) for p in range(n)]


def contact_laws(scene) -> list:
    """The [contact] tables of the laws a scene's pairs use or mix: the scene's, each pair
    table's. Every mixed parameter lies between its partners' (both rules are means), so a
    bound over these laws holds for every pair."""
    return [scene.contact] + [c for _, c in pair_contacts(scene)]


def mixed(a, b, rules=MIXING) -> tuple:
    """The mixed law (``rules``, MIXING by default) of two own laws, each a sequence of
    LAW_COLUMNS values."""
    return tuple(rules[k](float(x), float(y)) for k, x, y in zip(LAW_COLUMNS, a, b))


def pair_table(scene, dt: float) -> np.ndarray:
    """The kernels' table of the pair laws (see above); [0, 0, columns] without pair tables."""
    if not scene.pairs:
        return np.zeros((0, 0, len(LAW_COLUMNS)))
    own = [law_params(c, dt)[1:] for c in own_contacts(scene)]
    n = len(own)
    table = np.empty((n, n, len(LAW_COLUMNS)))
    rules = mixing_rules(scene.contact, MIXING)
    for p in range(n):
        for q in range(n):
            table[p, q] = mixed(own[p], own[q], rules)
    for (p, q), c in pair_contacts(scene):
        table[p, q] = table[q, p] = law_params(c, dt)[1:]
    return table


@nb.njit(**INLINE)
def pair_law(table, p, q, law, o):
    """The LawParams of a contact between partners p and q: row (p, q) of ``table``
    (Params.pair_law) with ``law``'s dt, or ``law`` itself without pair tables."""
    if not o.pairs:
        return law
    return LawParams(law.dt, table[p, q, 0], table[p, q, 1], table[p, q, 2], table[p, q, 3],
                     table[p, q, 4], table[p, q, 5], table[p, q, 6], table[p, q, 7],
                     table[p, q, 8])


@nb.njit(**INLINE)
def ring_partner(table, ring):
    """The partner number of ring 1 (inner) or 2 (outer) in ``table``."""
    return table.shape[0] - 3 + ring

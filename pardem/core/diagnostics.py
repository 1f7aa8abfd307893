"""Read-only measurements of the state: energies, the largest overlap, and the contact tables
that output and averaging report.

Stage: diagnostics and output. Nothing here changes the state. The contact tables take the
normal and tangential forces the last force evaluation applied (``Pairs.fn``, ``ft``,
``wall_fn``, ``wall_ft``), so they report what the step did; only the geometry (normal,
overlap) is computed here, from the positions those forces were computed at.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..contact.model import elastic_energy, history_columns
from ..contact.params import LAW_COLUMNS
from ..contact.pairs import pair_law, ring_partner
from .jit import JIT
from ..boundaries.walls import ring_surface

# A contact counts as sliding when its tangential force is at the Coulomb limit: the cap sets
# |f_t| = mu |f_n| up to rounding.
SLIDING = 1.0 - 1e-9


@nb.njit(**JIT)
def pair_overlap(ps, i, j):
    """Overlap (m) of disks i and j (negative when apart)."""
    return ps.radius[i] + ps.radius[j] - math.hypot(ps.x[i, 0] - ps.x[j, 0],
                                                    ps.x[i, 1] - ps.x[j, 1])


@nb.njit(**JIT)
def kinetic_energy(ps, n_owned):
    """Translational + rotational kinetic energy (J) of the moving particles."""
    e = 0.0
    for i in range(n_owned):
        m = ps.mass[i]
        e += 0.5 * m * (ps.v[i, 0] ** 2 + ps.v[i, 1] ** 2)
        e += 0.0625 * m * (2.0 * ps.radius[i]) ** 2 * ps.omega[i] ** 2  # I = m d^2/8
    return e


@nb.njit(**JIT)
def elastic_energy_pairs(ps, pairs, prm, o, n_own):
    """Energy (J) stored in the springs of touching particle pairs whose lower-gid partner is
    owned (index < n_own), so that no pair is counted on two ranks."""
    e = 0.0
    for k in range(pairs.count[0]):
        if pairs.i[k] < n_own:
            ai, aj = ps.radius[pairs.i[k]], ps.radius[pairs.j[k]]
            e += elastic_energy(pair_overlap(ps, pairs.i[k], pairs.j[k]), ai * aj / (ai + aj),
                                pairs.hist, k, pair_law(prm.pair_law, ps.species[pairs.i[k]],
                                                        ps.species[pairs.j[k]], prm.law, o), o)
    return e


@nb.njit(**JIT)
def elastic_energy_rings(ps, pairs, prm, o, r_out):
    """Energy (J) in the springs of contacts with the flat ring surfaces (outer radius r_out
    now)."""
    e = 0.0
    for q in range(pairs.wall_count[0]):
        i = pairs.wall[q]
        ring, _, _, delta = ring_surface(ps.x[i, 0], ps.x[i, 1], ps.radius[i], 0.0, r_out,
                                         prm.rings)
        law = pair_law(prm.pair_law, ps.species[i], ring_partner(prm.pair_law, ring), prm.law, o)
        e += elastic_energy(delta, ps.radius[i], ps.hist_wall, i, law, o)
    return e


@nb.njit(**JIT)
def max_overlap_ratio(ps, pairs, prm, r_out):
    """Largest overlap over the diameter of the smaller free particle involved, over disk-disk,
    disk-wall-disk and disk-flat-ring contacts (0 when nothing touches)."""
    worst = 0.0
    for k in range(pairs.count[0]):
        i, j = pairs.i[k], pairs.j[k]  # i has the lower gid, so it is a free particle
        d = pair_overlap(ps, i, j)
        a = min(ps.radius[i], ps.radius[j]) if ps.kind[j] == 0 else ps.radius[i]
        worst = max(worst, d / (2.0 * a))
    for q in range(pairs.wall_count[0]):
        i = pairs.wall[q]
        d = ring_surface(ps.x[i, 0], ps.x[i, 1], ps.radius[i], 0.0, r_out, prm.rings).delta
        worst = max(worst, d / (2.0 * ps.radius[i]))
    return worst


@nb.njit(**JIT)
def touching_pairs(ps, pairs, n_own):
    """Indices into the pair list of the pairs that touch now and whose lower-gid partner is
    owned (index < n_own)."""
    out = np.empty(pairs.count[0], np.int64)
    m = 0
    for k in range(pairs.count[0]):
        i, j = pairs.i[k], pairs.j[k]
        if i >= n_own:
            continue
        dx = ps.x[i, 0] - ps.x[j, 0]
        dy = ps.x[i, 1] - ps.x[j, 1]
        rs = ps.radius[i] + ps.radius[j]
        if dx * dx + dy * dy < rs * rs:
            out[m] = k
            m += 1
    return out[:m]


@nb.njit(**JIT)
def touching_rings(ps, pairs, prm, r_out):
    """``(q, ring)``: the ring candidates that touch a flat ring surface now (index into the
    candidate list) and which ring (1 inner, 2 outer)."""
    q_out = np.empty(pairs.wall_count[0], np.int64)
    ring_out = np.empty(pairs.wall_count[0], np.int64)
    m = 0
    for q in range(pairs.wall_count[0]):
        i = pairs.wall[q]
        ring, _, _, delta = ring_surface(ps.x[i, 0], ps.x[i, 1], ps.radius[i], 0.0, r_out,
                                         prm.rings)
        if ring != 0 and delta > 0.0:
            q_out[m] = q
            ring_out[m] = ring
            m += 1
    return q_out[:m], ring_out[:m]


def _history(table: dict, hist: np.ndarray, o) -> None:
    """The history columns of touching contacts into a contact table: ``spring`` [M,2] (m, the
    Cundall-Strack spring xi; zeros without friction), ``displacement`` [M,2] (m, the paper's
    total tangential displacement eta, eq. 1.3, where tracked) and ``rolling`` [M] (m, the
    rolling spring, where on)."""
    names = history_columns(o)
    col = {name: c for c, name in enumerate(names)}
    rows = len(table["normal_force"])
    table["spring"] = (hist[:, [col["spring_x"], col["spring_y"]]].copy() if o.friction
                       else np.zeros((rows, 2)))
    if o.eta:
        table["displacement"] = hist[:, [col["eta_x"], col["eta_y"]]].copy()
    if o.rolling:
        table["rolling"] = hist[:, col["rolling"]].copy()


def mobilisation(normal_force: np.ndarray, tangential_force: np.ndarray, mu,
                 friction: bool) -> np.ndarray:
    """|f_t| / (mu |f_n|): 1 at the Coulomb limit (0 without friction; 1 where f_n = 0); mu
    one coefficient or one per contact."""
    if not friction:
        return np.zeros_like(normal_force)
    with np.errstate(divide="ignore", invalid="ignore"):
        m = np.hypot(tangential_force[:, 0], tangential_force[:, 1]) / (mu * np.abs(normal_force))
    return np.where(np.isfinite(m), m, 1.0)


def contact_table(ps, pairs, prm, o, n_own: int, local_index: bool = False
                  ) -> dict[str, np.ndarray]:
    """Touching particle pairs whose lower-gid partner is owned (index < n_own): ``ids`` [M,2]
    (gid of i < gid of j), ``normal`` [M,2] (unit, from j to i), ``overlap`` [M] (m),
    ``normal_force`` [M] (N, on i along n), ``tangential_force`` [M,2] (N, on i), as the last
    step applied them; ``mobilised`` [M] (|f_t|/(mu |f_n|)), ``sliding`` [M] (int32, 1 at the
    Coulomb limit); the history columns (``_history``), in i's orientation. Forces on j are
    the negatives. ``local_index`` adds ``index`` [M,2], the pair's storage indices on this
    rank. ``o``: the run's contact.model.ContactOptions."""
    k = touching_pairs(ps, pairs, n_own)
    i, j = pairs.i[k], pairs.j[k]
    d = ps.x[i] - ps.x[j]
    dist = np.hypot(d[:, 0], d[:, 1])
    fn, ft = pairs.fn[k], pairs.ft[k]
    mu = (prm.pair_law[ps.species[i], ps.species[j], LAW_COLUMNS.index("mu")] if o.pairs
          else prm.law.mu)
    mobilised = mobilisation(fn, ft, mu, o.friction)
    table = {"ids": np.column_stack([ps.gid[i], ps.gid[j]]), "normal": d / dist[:, None],
             "overlap": ps.radius[i] + ps.radius[j] - dist, "normal_force": fn.copy(),
             "tangential_force": ft.copy(), "mobilised": mobilised,
             "sliding": (mobilised >= SLIDING).astype(np.int32)}
    _history(table, pairs.hist[k] if pairs.hist.shape[0] else pairs.hist, o)
    if local_index:
        table["index"] = np.column_stack([i, j])
    return table


def ring_contact_table(ps, pairs, prm, o, r_out: float) -> dict[str, np.ndarray]:
    """Touching contacts of free particles with the flat ring surfaces (outer radius r_out
    now): ``index`` [M] (storage index), ``id`` [M], ``ring`` [M] (1 inner, 2 outer),
    ``normal`` [M,2] (unit, from the surface to the particle), ``overlap`` [M] (m),
    ``normal_force`` [M] (N, along n), ``tangential_force`` [M,2] (N), as the last step
    applied them, and the history columns (``_history``)."""
    q, ring = touching_rings(ps, pairs, prm, r_out)
    idx = pairs.wall[q]
    x = ps.x[idx]
    r = np.hypot(x[:, 0], x[:, 1])
    er = x / r[:, None]
    inner = ring == 1
    table = {"index": idx, "id": ps.gid[idx], "ring": ring,
             "normal": np.where(inner[:, None], er, -er),
             "overlap": np.where(inner, ps.radius[idx] - (r - prm.rings.r_in),
                                 ps.radius[idx] - (r_out - r)),
             "normal_force": pairs.wall_fn[q].copy(), "tangential_force": pairs.wall_ft[q].copy()}
    _history(table, ps.hist_wall[idx] if ps.hist_wall.shape[0] else ps.hist_wall, o)
    return table

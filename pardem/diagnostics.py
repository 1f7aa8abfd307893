"""Read-only measurements of the state: energies, largest overlap, per-contact table.

Stage: diagnostics and output. Nothing here changes the state; the contact table re-evaluates the
contact law at the current (synchronous) velocities without touching the springs, so its normal
force can differ from the one used in the last step by the damping term's half-step change.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .jit import JIT


@nb.njit(**JIT)
def pair_overlap(ps, i, j):
    """Overlap (m) of disks i and j (negative when apart)."""
    return ps.radius[i] + ps.radius[j] - math.hypot(ps.x[i, 0] - ps.x[j, 0],
                                                    ps.x[i, 1] - ps.x[j, 1])


@nb.njit(**JIT)
def ring_overlap(ps, i, prm, r_out):
    """Overlap (m) of disk i with the nearer flat ring surface (outer radius r_out); a ring
    without its flat surface (Params.flat_in, flat_out) cannot overlap."""
    r = math.hypot(ps.x[i, 0], ps.x[i, 1])
    inner = ps.radius[i] - (r - prm.r_in) if prm.flat_in != 0.0 else -math.inf
    outer = ps.radius[i] - (r_out - r) if prm.flat_out != 0.0 else -math.inf
    return max(inner, outer)


@nb.njit(**JIT)
def kinetic_energy(ps, n_move):
    """Translational + rotational kinetic energy (J) of the moving particles."""
    e = 0.0
    for i in range(n_move):
        m = ps.mass[i]
        e += 0.5 * m * (ps.v[i, 0] ** 2 + ps.v[i, 1] ** 2)
        e += 0.0625 * m * (2.0 * ps.radius[i]) ** 2 * ps.omega[i] ** 2  # I = m d^2/8
    return e


@nb.njit(**JIT)
def elastic_energy(ps, pairs, prm, n_own):
    """Energy (J) stored in the normal and tangential springs of touching particle pairs whose
    lower-gid partner is owned (index < n_own), so that no pair is counted on two ranks."""
    e = 0.0
    for k in range(pairs.count[0]):
        if pairs.i[k] >= n_own:
            continue
        d = pair_overlap(ps, pairs.i[k], pairs.j[k])
        if d > 0.0:
            e += 0.5 * prm.k_n * d * d
            if pairs.xi.shape[0] > 0:
                e += 0.5 * prm.k_t * (pairs.xi[k, 0] ** 2 + pairs.xi[k, 1] ** 2)
    return e


@nb.njit(**JIT)
def ring_elastic_energy(ps, pairs, prm, r_out):
    """Energy (J) in the normal springs of contacts with the flat ring surfaces (outer radius
    r_out at the current time)."""
    e = 0.0
    for q in range(pairs.wall_count[0]):
        d = ring_overlap(ps, pairs.wall[q], prm, r_out)
        if d > 0.0:
            e += 0.5 * prm.k_n * d * d
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
        d = ring_overlap(ps, i, prm, r_out)
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


# A contact counts as sliding at |f_t| >= 0.999 mu |f_n|: the cap sets |f_t| = mu |f_n| with the
# step's f_n, whose damping part used the predicted velocities; the reported f_n uses the
# synchronous ones and differs by O(dt) in the damping term only.
SLIDING = 0.999


def contact_table(ps, pairs, prm, friction: bool, damping: bool, n_own: int,
                  local_index: bool = False) -> dict[str, np.ndarray]:
    """Touching particle pairs whose lower-gid partner is owned (index < n_own): ``ids`` [M,2]
    (gid of i < gid of j), ``normal`` [M,2] (unit, from j to i), ``overlap`` [M] (m),
    ``normal_force`` [M] (N, on i along n), ``tangential_force`` [M,2] (N, on i), ``spring``
    [M,2] (m, xi), ``mobilised`` [M] (|f_t|/(mu |f_n|)), ``sliding`` [M] (int32, 1 at the
    cap). Forces on j are the negatives. ``local_index`` adds ``index`` [M,2], the pair's
    storage indices on this rank. Where the run tracks it (history columns 2-3),
    ``displacement`` [M,2] (m) is the paper's total tangential displacement eta (eq. 1.3), in
    i's orientation like the spring."""
    k = touching_pairs(ps, pairs, n_own)
    i, j = pairs.i[k], pairs.j[k]
    d = ps.x[i] - ps.x[j]
    dist = np.hypot(d[:, 0], d[:, 1])
    n = d / dist[:, None]
    overlap = ps.radius[i] + ps.radius[j] - dist
    fn = prm.k_n * overlap
    if damping:
        s = ps.radius[i] * ps.omega[i] + ps.radius[j] * ps.omega[j]
        dv = ps.v[i] - ps.v[j] + s[:, None] * np.column_stack([n[:, 1], -n[:, 0]])
        fn = fn - prm.gamma_n * np.einsum("ij,ij->i", dv, n)
    hist = pairs.xi[k] if friction else np.zeros((k.size, 2))
    xi = hist[:, :2]
    with np.errstate(divide="ignore", invalid="ignore"):
        mobilised = np.hypot(xi[:, 0], xi[:, 1]) * prm.k_t / (prm.mu * np.abs(fn))
    mobilised = np.where(np.isfinite(mobilised), mobilised, 1.0) if friction else 0.0 * fn
    table = {"ids": np.column_stack([ps.gid[i], ps.gid[j]]), "normal": n, "overlap": overlap,
             "normal_force": fn, "tangential_force": -prm.k_t * xi, "spring": xi.copy(),
             "mobilised": mobilised, "sliding": (mobilised >= SLIDING).astype(np.int32)}
    if hist.shape[1] == 4:
        table["displacement"] = hist[:, 2:4].copy()
    if local_index:
        table["index"] = np.column_stack([i, j])
    return table


def ring_contact_table(ps, pairs, prm, r_out: float, r_out_rate: float, friction: bool,
                       damping: bool) -> dict[str, np.ndarray]:
    """Touching contacts of free particles with the flat ring surfaces: ``index`` [M] (storage
    index), ``id`` [M], ``ring`` [M] (1 inner, 2 outer), ``normal`` [M,2] (unit, from the
    surface to the particle), ``overlap`` [M] (m), ``normal_force`` [M] (N, along n),
    ``tangential_force`` [M,2] (N), ``spring`` [M,2] (m), and ``displacement`` [M,2] (m, eta)
    where tracked. Same law as the step loop, with synchronous velocities."""
    cand = pairs.wall[: pairs.wall_count[0]]
    x = ps.x[cand]
    r = np.hypot(x[:, 0], x[:, 1])
    a = ps.radius[cand]
    inner = (r - prm.r_in < a) & (prm.flat_in != 0.0)
    outer = ~inner & (r_out - r < a) & (prm.flat_out != 0.0)
    keep = inner | outer
    idx, x, r, a, inner = cand[keep], x[keep], r[keep], a[keep], inner[keep]
    er = x / r[:, None]
    n = np.where(inner[:, None], er, -er)
    overlap = np.where(inner, a - (r - prm.r_in), a - (r_out - r))
    fn = prm.k_n * overlap
    if damping:
        # normal speed of the contact point relative to the surface (the outer ring moves
        # radially at r_out_rate; the inner ring only turns)
        wall_v = np.where(inner[:, None], 0.0, r_out_rate * er)
        fn = fn - prm.gamma_n * np.einsum("ij,ij->i", ps.v[idx] - wall_v, n)
    hist = ps.xi_wall[idx] if friction else np.zeros((idx.size, 2))
    xi = hist[:, :2]
    table = {"index": idx, "id": ps.gid[idx], "ring": np.where(inner, 1, 2), "normal": n,
             "overlap": overlap, "normal_force": fn, "tangential_force": -prm.k_t * xi,
             "spring": xi.copy()}
    if hist.shape[1] == 4:
        table["displacement"] = hist[:, 2:4].copy()
    return table

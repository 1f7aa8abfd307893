"""The arithmetic behind the derived ring fields: a view of one set of (time-averaged) ring sums
with the ring geometry (``RingView``), 2x2 tensor inverses and eigen-analysis, and the
exponential fit of the velocity profile. The fields themselves are defined in ``fields.py``.

Stage: averaging. Everything here works on whole arrays of rings and never raises on a ring
without particles or contacts: such rings give NaN.
"""

from __future__ import annotations

import math

import numpy as np


class RingView:
    """Ring sums s [n_rings, columns] (``col``: column name -> index) with the geometry: ring
    centres r (m), width dr (m), disk height h (m), r_tilde, k'_n = k_n/h (N/m^2) and the wall
    speed Omega R_i (m/s) of the paper's normalisations. ``field(name)`` evaluates a field of
    the registry once and keeps it, so fields can build on each other."""

    def __init__(self, s: np.ndarray, col: dict[str, int], r: np.ndarray, dr: float, h: float,
                 r_tilde, k_n_2d: float, wall_speed: float, registry: dict):
        self.s, self.col, self.r, self.dr, self.h = s, col, r, dr, h
        self.r_tilde, self.k_n_2d, self.wall_speed = r_tilde, k_n_2d, wall_speed
        self.vol_ring = 2.0 * math.pi * h * r * dr  # m^3
        self._registry, self._done = registry, {}
        self._inv = None

    def sum(self, name: str) -> np.ndarray:
        return self.s[:, self.col[name]]

    def field(self, name: str) -> np.ndarray:
        if name not in self._done:
            with np.errstate(invalid="ignore", divide="ignore"):
                self._done[name] = self._registry[name].compute(self)
        return self._done[name]

    def tensor(self, prefix: str) -> np.ndarray:
        """The 2x2 polar tensor [n_rings, 2, 2] of the sums prefix_rr, _rphi, _phir, _phiphi."""
        return np.stack([self.sum(f"{prefix}_{c}") for c in ("rr", "rphi", "phir", "phiphi")],
                        axis=-1).reshape(-1, 2, 2)

    def fabric_inverse(self) -> np.ndarray:
        """A = F^-1 of every ring (NaN where F is singular)."""
        if self._inv is None:
            self._inv = inverse(self.tensor("fabric") / self.vol_ring[:, None, None])
        return self._inv


def eigen(t: np.ndarray):
    """Trace, deviator (T_max - T_min) and angle (deg, of the major eigenvector from e_r, in
    (-90, 90]) of the symmetric part of 2x2 tensors t [n,2,2]."""
    rr, pp = t[:, 0, 0], t[:, 1, 1]
    rp = 0.5 * (t[:, 0, 1] + t[:, 1, 0])
    half_diff = 0.5 * (rr - pp)
    radius = np.hypot(half_diff, rp)
    return rr + pp, 2.0 * radius, np.degrees(0.5 * np.arctan2(2.0 * rp, rr - pp))


def exponential_fit(r_tilde: np.ndarray, v: np.ndarray, lo: float = 0.25, hi: float = 8.1):
    """The primary fit (docs/roughness.md): v = v0 exp(-r_tilde/s) by ordinary least squares
    on v itself over lo <= r_tilde <= hi (the paper's range), every ring one point of equal
    weight. For a given s the best v0 is sum(v e)/sum(e^2), e = exp(-r/s); s by golden-section
    search of the residual over 0.05 <= s <= 50. NaN if fewer than 3 finite values, or if no
    ring moves (v = 0 everywhere: no decay to fit; any s fits with v0 = 0)."""
    sel = (r_tilde >= lo) & (r_tilde <= hi) & np.isfinite(v)
    if sel.sum() < 3 or not np.any(v[sel] != 0):
        return math.nan, math.nan
    r, v = r_tilde[sel], v[sel]

    def cost(s):
        e = np.exp(-r / s)
        v0 = (v @ e) / (e @ e)
        return float(np.sum((v - v0 * e) ** 2)), float(v0)

    a, b = math.log(0.05), math.log(50.0)
    g = (math.sqrt(5) - 1) / 2
    for _ in range(80):
        c, d = b - g * (b - a), a + g * (b - a)
        if cost(math.exp(c))[0] < cost(math.exp(d))[0]:
            b = d
        else:
            a = c
    s = math.exp(0.5 * (a + b))
    return cost(s)[1], s


def log_exponential_fit(r_tilde: np.ndarray, v: np.ndarray, lo: float = 0.25,
                        hi: float = 8.1):
    """The secondary fit: a straight line through log v over lo <= r_tilde <= hi, unweighted,
    rings with v <= 0 left out; NaN if fewer than 3 positive values."""
    sel = (r_tilde >= lo) & (r_tilde <= hi) & (v > 0) & np.isfinite(v)
    if sel.sum() < 3:
        return math.nan, math.nan
    slope, icpt = np.polyfit(r_tilde[sel], np.log(v[sel]), 1)
    return math.exp(icpt), -1.0 / slope if slope < 0 else math.inf


def inverse(t: np.ndarray) -> np.ndarray:
    """2x2 inverses; NaN where the determinant is zero (a ring without contacts): never a crash,
    never a silent zero."""
    det = t[:, 0, 0] * t[:, 1, 1] - t[:, 0, 1] * t[:, 1, 0]
    scale = np.abs(t).max(axis=(1, 2))
    singular = ~(np.abs(det) > 1e-12 * scale**2)
    det = np.where(singular, np.nan, det)
    inv = np.empty_like(t)
    inv[:, 0, 0] = t[:, 1, 1] / det
    inv[:, 1, 1] = t[:, 0, 0] / det
    inv[:, 0, 1] = -t[:, 0, 1] / det
    inv[:, 1, 0] = -t[:, 1, 0] / det
    return inv

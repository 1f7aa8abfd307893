"""The averaged quantities, defined once: the additive ring sums (``SUMS``: what one particle
adds to a ring, reduced over ranks and over time) and the fields derived from them
(``FIELDS``: ratios formed after the time average, SPEC §4; the paper's names and
normalisations). Adding a field: a ``Field`` entry here, and if it needs a new sum, a ``Sum``
entry plus the line in ``sums.accumulate`` that adds it.

Stage: averaging. Notation: per particle p (free particles only) in the local polar frame
(e_r, e_phi) at its centre; w its weight in the ring (weights.py), V^p = pi a^2 h (h the disk
height), C^p its contacts; per contact c of p: n the unit normal from the partner to p, f the
force on p, delta the overlap, l = -(a - delta/2) n the branch vector to the contact point,
Delta = delta n - t the contact displacement (t its tangential history: the paper's eta, or
the spring); tensor component ab = first vector's a times second's b, a, b in {r, phi};
l x f = l_r f_phi - l_phi f_r. V = 2 pi h r dr is the ring's volume. The minus signs make
compression positive.
"""

from __future__ import annotations

import math
from collections import namedtuple
from typing import Callable, NamedTuple

import numpy as np

from .boundary import LOAD_UNITS, LOADS
from .derived import RingView, eigen, exponential_fit, log_exponential_fit

COMPONENTS = ("rr", "rphi", "phir", "phiphi")


class Sum(NamedTuple):
    name: str
    unit: str
    definition: str


SUMS = (
    Sum("vol", "m^3", "Sum w V^p"),
    Sum("count", "1", "Sum w (particles)"),
    Sum("mass", "kg", "Sum w m^p"),
    Sum("mom_r", "m^4/s", "Sum w V^p v_r^p"),
    Sum("mom_phi", "m^4/s", "Sum w V^p v_phi^p"),
    Sum("spin", "m^3/s", "Sum w V^p omega^p"),
    Sum("coord", "m^3", "Sum w V^p C^p"),
    *(Sum(f"fabric_{c}", "m^3", "Sum w V^p Sum_c n_a n_b") for c in COMPONENTS),
    *(Sum(f"stress_{c}", "N m", "-Sum w Sum_c f_a l_b") for c in COMPONENTS),
    *(Sum(f"deform_{c}", "m^2", "-Sum w Sum_c Delta_a l_b") for c in COMPONENTS),
    Sum("couple_r", "N m^2", "-Sum w Sum_c (l x f) l_r"),
    Sum("couple_phi", "N m^2", "-Sum w Sum_c (l x f) l_phi"),
    Sum("curv_r", "m^3", "-Sum w Sum_c (l x Delta) l_r"),
    Sum("curv_phi", "m^3", "-Sum w Sum_c (l x Delta) l_phi"),
    Sum("contacts", "1", "Sum w C^p (C^p / count: the number-weighted contact number)"),
    Sum("diam", "m", "Sum w d^p (d^p = 2 a)"),
    Sum("mmom_r", "kg m/s", "Sum w m^p v_r^p"),
    Sum("mmom_phi", "kg m/s", "Sum w m^p v_phi^p"),
    Sum("kin_rr", "kg m^2/s^2", "Sum w m^p v_r^p v_r^p"),
    Sum("kin_rphi", "kg m^2/s^2", "Sum w m^p v_r^p v_phi^p"),
    Sum("kin_phiphi", "kg m^2/s^2", "Sum w m^p v_phi^p v_phi^p"),
)
COLUMNS = tuple(s.name for s in SUMS)
COL = {name: k for k, name in enumerate(COLUMNS)}
S = namedtuple("SumIndex", COLUMNS)(*range(len(COLUMNS)))  # column indices by name (kernels)
N_COLUMNS = len(COLUMNS)
UNITS = {s.name: s.unit for s in SUMS}


class Field(NamedTuple):
    name: str
    unit: str
    definition: str
    compute: Callable[[RingView], np.ndarray]


def _tensor_fields(name: str, unit: str, meaning: str, of: Callable[[RingView], np.ndarray]):
    """Components, trace, deviator and orientation of a 2x2 tensor field."""
    def part(k):
        return lambda v: eigen(v.field(f"_{name}"))[k]

    return (Field(f"_{name}", unit, meaning, of),
            *(Field(f"{name}_{c}", unit, f"{meaning}, {c} component",
                    lambda v, a=a, b=b: v.field(f"_{name}")[:, a, b])
              for a, b, c in ((0, 0, "rr"), (0, 1, "rphi"), (1, 0, "phir"), (1, 1, "phiphi"))),
            Field(f"tr_{name}", unit, f"trace of {meaning}", part(0)),
            Field(f"dev_{name}", unit, f"deviator (T_max - T_min) of {meaning}", part(1)),
            Field(f"angle_{name}", "deg", f"angle of the major eigenvector of {meaning} from "
                  "e_r", part(2)))


def _curvature(v: RingView) -> np.ndarray:
    curv = v.s[:, [COL["curv_r"], COL["curv_phi"]]]
    return (math.pi * v.h / v.vol_ring)[:, None] * np.einsum("ka,kab->kb", curv,
                                                             v.fabric_inverse())


def _kinetic_stress(v: RingView) -> np.ndarray:
    """(1/V) Sum w m v'(x)v' with v' = v - u, u = mmom/mass the ring's mass-weighted mean
    velocity (over the samples averaged): second moment minus mean flow, from additive sums."""
    m = v.sum("mass")
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.stack([v.sum("mmom_r"), v.sum("mmom_phi")], axis=1) / m[:, None]
    moment = np.empty((m.size, 2, 2))
    moment[:, 0, 0] = v.sum("kin_rr")
    moment[:, 0, 1] = moment[:, 1, 0] = v.sum("kin_rphi")
    moment[:, 1, 1] = v.sum("kin_phiphi")
    flux = moment - m[:, None, None] * u[:, :, None] * u[:, None, :]
    return np.where(m[:, None, None] > 0, flux, 0.0) / v.vol_ring[:, None, None]


def _inertial_number(v: RingView) -> np.ndarray:
    """I = gamma_dot d sqrt(rho / p): gamma_dot = 2 |D_rphi|, d the ring's mean diameter, rho
    the disks' material density (mass / vol), p the pressure with the kinetic part."""
    p = v.field("pressure") + v.field("pressure_kin")
    d = v.sum("diam") / v.sum("count")
    rho = v.sum("mass") / v.sum("vol")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(p > 0, 2.0 * np.abs(v.field("D_rphi")) * d * np.sqrt(rho / p), np.nan)


def _fit(v: RingView, k: int, how=exponential_fit) -> np.ndarray:
    if v.r_tilde is None:
        return np.array(math.nan)
    return np.array(how(v.r_tilde, v.field("v_phi_norm"))[k])


FIELDS = (
    Field("nu", "1", "volume fraction vol / V", lambda v: v.sum("vol") / v.vol_ring),
    Field("v_r", "m/s", "mean radial velocity mom_r / vol",
          lambda v: v.sum("mom_r") / v.sum("vol")),
    Field("v_phi", "m/s", "mean angular velocity mom_phi / vol",
          lambda v: v.sum("mom_phi") / v.sum("vol")),
    Field("omega", "rad/s", "mean spin spin / vol", lambda v: v.sum("spin") / v.sum("vol")),
    Field("C", "1", "volume-weighted contact number coord / vol (tr F = nu C exactly)",
          lambda v: v.sum("coord") / v.sum("vol")),
    Field("C_number", "1", "contacts per particle contacts / count (the paper's C)",
          lambda v: v.sum("contacts") / v.sum("count")),
    *_tensor_fields("F", "1", "the fabric tensor F = fabric / V",
                    lambda v: v.tensor("fabric") / v.vol_ring[:, None, None]),
    *_tensor_fields("sigma", "N/m^2", "the stress sigma = stress / V",
                    lambda v: v.tensor("stress") / v.vol_ring[:, None, None]),
    *_tensor_fields("sigma_kin", "N/m^2", "the kinetic (streaming) stress (1/V) Sum w m v'v', "
                    "v' the velocity relative to the ring's mean flow", _kinetic_stress),
    Field("pressure", "N/m^2", "contact pressure tr sigma / 2",
          lambda v: 0.5 * v.field("tr_sigma")),
    Field("pressure_kin", "N/m^2", "kinetic pressure tr sigma_kin / 2",
          lambda v: 0.5 * v.field("tr_sigma_kin")),
    Field("inertial_number", "1", "I = 2 |D_rphi| d sqrt(rho / p), d the mean diameter, rho "
          "the disks' density, p = pressure + pressure_kin", _inertial_number),
    *_tensor_fields("eps", "1", "the elastic deformation gradient eps = (pi h / V) deform . "
                    "F^-1", lambda v: (math.pi * v.h / v.vol_ring)[:, None, None]
                    * v.tensor("deform") @ v.fabric_inverse()),
    Field("M_zr", "N/m", "couple stress couple_r / V", lambda v: v.sum("couple_r") / v.vol_ring),
    Field("M_zphi", "N/m", "couple stress couple_phi / V",
          lambda v: v.sum("couple_phi") / v.vol_ring),
    Field("kappa_zr", "m", "curvature (pi h / V) curv . F^-1, r component",
          lambda v: _curvature(v)[:, 0]),
    Field("kappa_zphi", "m", "curvature (pi h / V) curv . F^-1, phi component",
          lambda v: _curvature(v)[:, 1]),
    Field("D_rphi", "1/s", "strain rate (dv_phi/dr - v_phi/r)/2",
          lambda v: 0.5 * (_dv(v) - v.field("v_phi") / v.r)),
    Field("W_rphi", "1/s", "vorticity (dv_phi/dr + v_phi/r)/2",
          lambda v: 0.5 * (_dv(v) + v.field("v_phi") / v.r)),
    Field("excess_spin", "rad/s", "omega - W_rphi",
          lambda v: v.field("omega") - v.field("W_rphi")),
    Field("stiffness", "1", "2 pi E / k'_n = (2 pi / k'_n) tr sigma / tr eps",
          lambda v: 2.0 * math.pi / v.k_n_2d * v.field("tr_sigma") / v.field("tr_eps")),
    Field("shear_resistance", "1", "pi G / k'_n = (pi / k'_n) dev sigma / dev eps",
          lambda v: math.pi / v.k_n_2d * v.field("dev_sigma") / v.field("dev_eps")),
    Field("mu_c", "N/m^2", "torque resistance |M_zr| / |kappa_zr| (the paper's ratio of "
          "magnitudes)", lambda v: np.abs(v.field("M_zr")) / np.abs(v.field("kappa_zr"))),
    Field("mu_c_signed", "N/m^2", "M_zr / kappa_zr",
          lambda v: v.field("M_zr") / v.field("kappa_zr")),
    Field("v_phi_norm", "1", "v_phi / (Omega R_i)", lambda v: v.field("v_phi") / v.wall_speed),
    Field("shear_torque", "N m", "2 pi h r^2 sigma_phir: the torque passed outwards through "
          "the ring by the contacts", lambda v: 2.0 * math.pi * v.h * v.r * v.r
          * v.field("sigma_phir")),
    Field("shear_torque_total", "N m", "2 pi h r^2 (sigma_phir + sigma_kin_phir): contacts and "
          "momentum flux", lambda v: 2.0 * math.pi * v.h * v.r * v.r
          * (v.field("sigma_phir") + v.field("sigma_kin_phir"))),
    Field("fit_v0", "1", "v0 of v_phi_norm = v0 exp(-r_tilde/s) over 0.25 <= r_tilde <= 8.1, "
          "least squares on v (the primary fit)", lambda v: _fit(v, 0)),
    Field("fit_s", "1", "s of that fit", lambda v: _fit(v, 1)),
    Field("fit_v0_log", "1", "v0 of the same law by a straight line through log v_phi_norm",
          lambda v: _fit(v, 0, log_exponential_fit)),
    Field("fit_s_log", "1", "s of the log fit", lambda v: _fit(v, 1, log_exponential_fit)),
)
REGISTRY = {f.name: f for f in FIELDS}
FIELD_UNITS = {"r": "m", "r_tilde": "1", **LOAD_UNITS,
               **{f.name: f.unit for f in FIELDS if not f.name.startswith("_")}}


def _dv(v: RingView) -> np.ndarray:
    return np.gradient(v.field("v_phi"), v.r) if v.r.size > 1 else np.zeros_like(v.r)


def derived(s: np.ndarray, r: np.ndarray, dr: float, h: float, r_tilde: np.ndarray | None = None,
            k_n_2d: float = 1.0, wall_speed: float = 1.0) -> dict[str, np.ndarray]:
    """Every field of the registry from (time-averaged) ring sums s [n_rings, N_COLUMNS]; k_n_2d
    = k'_n = k_n/h (N/m^2) and wall_speed = Omega R_i (m/s) set the paper's normalisations."""
    view = RingView(s, COL, r, dr, h, r_tilde, k_n_2d, wall_speed, REGISTRY)
    return {f.name: view.field(f.name) for f in FIELDS if not f.name.startswith("_")}


def group_fields(sums: np.ndarray, loads: np.ndarray, groups: list[np.ndarray],
                 args: tuple) -> list[dict[str, np.ndarray]]:
    """The fields (and the mean ring loads, boundary.LOADS) of each group of samples: the
    sums [samples, rings, columns] and loads [samples, len(LOADS)] averaged over the group's
    samples first, as for the time average (fields are ratios formed after averaging)."""
    out = []
    for g in groups:
        f = derived(sums[g].mean(axis=0), *args)
        for k, name in enumerate(LOADS):
            f[name] = np.array(loads[g, k].mean())
        out.append(f)
    return out

"""Ring averages of a run: sampling (in situ), time averaging, derived continuum fields, files.

Stage: averaging. ``RingAverager.sample(sim)`` adds one sample (collective under MPI: one
Allreduce). ``fields()`` forms the continuum quantities from the time-averaged sums (SPEC §4:
average the sums first, then take ratios and A = <F>^-1), with standard errors from up to 8
consecutive blocks of samples (see ``fields``). ``write(dir)`` writes rings.h5, rings.csv and
rings.vtu (the annulus mesh for ParaView, see ``mesh.py``) atomically (rank 0);
``read_rings(dir)`` reads them back.

Fields (per ring, polar components; V = 2 pi h r dr the ring volume):
    r (m) ring centre; r_tilde = (r - R_i)/d_ref (d_ref: [averaging] reference_diameter)
    nu = vol/V; v_r, v_phi (m/s) = mom/vol; omega (rad/s) = spin/vol; C = coord/vol (volume-
    weighted contact number: tr F = nu C exactly); C_number = contacts/count (contacts per
    particle, number-weighted: the paper's C in tr F ~ nu C)
    F_ab = fabric/V; sigma_ab (N/m^2) = stress/V
    eps_ab = (pi h/V) deform . A with A = F^-1 (NaN where F is singular)
    M_zr, M_zphi (N/m) = couple/V; kappa_zr, kappa_zphi (m) = (pi h/V) curv . A (the
    SPEC's definition; the paper plots M/d^2 and kappa/d^2)
    tr_T, dev_T (T_max - T_min), angle_T (deg, major eigenvector from e_r) of the symmetric
    part of T = F, sigma, eps
    D_rphi, W_rphi = (dv_phi/dr -+ v_phi/r)/2 (1/s); excess_spin = omega - W_rphi
    stiffness = 2 pi E/k'_n = (2 pi/k'_n) tr sigma / tr eps; shear_resistance = pi G/k'_n =
    (pi/k'_n) dev sigma / dev eps; mu_c = |M_zr| / |kappa_zr| (N/m^2, the paper's ratio of
    magnitudes), mu_c_signed = M_zr / kappa_zr; k'_n = k_n/h
    v_phi_norm = v_phi/(Omega R_i); fit_v0, fit_s: v_phi_norm = v0 exp(-r_tilde/s) fitted
    over r_tilde in [0.25, 8.1] (scalars, in rings.h5 only)
    shear_torque (N m) = 2 pi h r^2 sigma_phir, the torque passed outwards through the ring
    (sigma_phir: force along e_phi across a surface normal to e_r, the tangential traction on a
    circle; sigma_rphi differs by the spin acceleration and equals it on time average: within
    0.2 % in the paper's runs);
    inner_torque (N m, scalar): the torque of the inner ring on the particles, from its
    contacts, averaged over the samples (steady state: shear_torque = inner_torque in every
    ring; per-sample values in rings.h5/inner_torque)
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import h5py
import numpy as np

from .collect import Sample, sample_simulation
from .mesh import write_rings_vtu
from .sums import COL, COLUMNS, N_COLUMNS, UNITS, accumulate, reduce_sums
from .weights import WEIGHTINGS

TENSORS = ("F", "sigma", "eps")
ERROR_BLOCKS = 8  # consecutive blocks of samples for the standard errors
FIELD_UNITS = {"r": "m", "r_tilde": "1", "nu": "1", "v_r": "m/s", "v_phi": "m/s",
               "omega": "rad/s", "C": "1", "C_number": "1", "M_zr": "N/m", "M_zphi": "N/m",
               "kappa_zr": "m", "kappa_zphi": "m"}
FIELD_UNITS.update({"tr_F": "1", "dev_F": "1", "angle_F": "deg", "tr_sigma": "N/m^2",
                    "dev_sigma": "N/m^2", "angle_sigma": "deg", "tr_eps": "1", "dev_eps": "1",
                    "angle_eps": "deg", "D_rphi": "1/s", "W_rphi": "1/s", "excess_spin": "rad/s",
                    "stiffness": "1", "shear_resistance": "1", "mu_c": "N/m^2",
                    "mu_c_signed": "N/m^2", "v_phi_norm": "1",
                    "fit_v0": "1", "fit_s": "1", "shear_torque": "N m", "inner_torque": "N m"})
for comp in ("rr", "rphi", "phir", "phiphi"):
    FIELD_UNITS[f"F_{comp}"] = "1"
    FIELD_UNITS[f"sigma_{comp}"] = "N/m^2"
    FIELD_UNITS[f"eps_{comp}"] = "1"


class RingAverager:
    """Rings of width ``dr`` (m) from ``r_in`` to ``r_out`` (m) about the axis."""

    def __init__(self, r_in: float, r_out: float, dr: float, weighting: str, height: float,
                 d_ref: float, k_n: float, omega_in: float, reducer=None):
        if weighting not in WEIGHTINGS:
            raise ValueError(f"weighting {weighting!r}: allowed are {sorted(WEIGHTINGS)}")
        self.r_in, self.dr, self.height, self.d_ref = r_in, dr, height, d_ref
        self.n_rings = max(int(math.ceil((r_out - r_in) / dr - 1e-9)), 1)
        self.kind = WEIGHTINGS[weighting]
        self.weighting = weighting
        self.reducer = reducer  # sums over the ranks (Simulation.decomp); None: one process
        self.k_n, self.omega_in = k_n, omega_in  # for 2 pi E / k'_n etc. and v_phi / (Omega R_i)
        self.samples: list[np.ndarray] = []
        self.times: list[float] = []
        self.torques: list[float] = []  # inner ring on the particles, N m, per sample

    def sample(self, sim) -> None:
        """Add the ring sums of the simulation's current state (collective under MPI)."""
        self.add(sample_simulation(sim), sim.time)

    def add(self, s: Sample, time: float) -> None:
        """Add one sample (this rank's particles; the totals are reduced over ranks)."""
        local = np.zeros((self.n_rings, N_COLUMNS))
        accumulate(*s[:-1], self.height, self.r_in, self.dr, self.kind, local)
        sums, scalars = reduce_sums(local, np.array([s.inner_torque]), self.reducer)
        self.samples.append(sums)
        self.torques.append(float(scalars[0]))
        self.times.append(time)

    @property
    def ring_centres(self) -> np.ndarray:
        return self.r_in + (np.arange(self.n_rings) + 0.5) * self.dr

    def fields(self) -> dict[str, np.ndarray]:
        """Time-averaged fields and their standard errors (key + "_err"). Errors come from
        block averages: the samples are cut into up to 8 consecutive blocks, each block's
        fields are formed from its averaged sums, and err = std(blocks) / sqrt(n_blocks).
        Consecutive samples are correlated, so the spread of single samples would understate
        the error; blocks longer than the correlation time do not."""
        if not self.samples:
            raise ValueError("no samples taken")
        stack = np.array(self.samples)
        r = self.ring_centres
        r_tilde = (r - self.r_in) / self.d_ref
        args = (r, self.dr, self.height, r_tilde, self.k_n / self.height,
                self.omega_in * self.r_in)
        torques = np.array(self.torques)
        mean = derived(stack.mean(axis=0), *args)
        mean["inner_torque"] = np.array(torques.mean())
        out = {"r": r, "r_tilde": r_tilde}
        blocks = np.array_split(np.arange(len(stack)), min(ERROR_BLOCKS, len(stack)))
        per = [derived(stack[b].mean(axis=0), *args) for b in blocks]
        for p, b in zip(per, blocks):
            p["inner_torque"] = np.array(torques[b].mean())
        for key, value in mean.items():
            out[key] = value
            if len(per) > 1:
                out[key + "_err"] = block_error(np.array([p[key] for p in per]))
        return out

    def write(self, out_dir: str | Path) -> None:
        """rings.h5 (fields, errors, raw sums per sample), rings.csv and rings.vtu; atomic."""
        out_dir = Path(out_dir)
        f = self.fields()
        tmp = out_dir / "rings.h5.tmp"
        with h5py.File(tmp, "w") as h5:
            h5.attrs.update({"format": "pardem-rings", "ring_width": self.dr,
                             "inner_radius": self.r_in, "weighting": self.weighting,
                             "height": self.height, "n_samples": len(self.samples),
                             "reference_diameter": self.d_ref})
            for key, value in f.items():
                h5.create_dataset(f"fields/{key}", data=value)
                h5[f"fields/{key}"].attrs["unit"] = FIELD_UNITS.get(key.removesuffix("_err"), "")
            h5.create_dataset("sums", data=np.array(self.samples))
            h5["sums"].attrs["columns"] = ",".join(COLUMNS)
            h5["sums"].attrs["units"] = ",".join(UNITS[c] for c in COLUMNS)
            h5.create_dataset("times", data=np.array(self.times))
            h5.create_dataset("inner_torque", data=np.array(self.torques))
            h5["inner_torque"].attrs["unit"] = "N m"
        os.replace(tmp, out_dir / "rings.h5")
        keys = [k for k in f if np.ndim(f[k]) == 1]  # per-ring columns (fit scalars: h5 only)
        header = ",".join(f"{k} [{FIELD_UNITS.get(k.removesuffix('_err'), '')}]" for k in keys)
        tmp = out_dir / "rings.csv.tmp"
        np.savetxt(tmp, np.column_stack([f[k] for k in keys]), delimiter=",", header=header,
                   comments="")
        os.replace(tmp, out_dir / "rings.csv")
        write_rings_vtu(out_dir / "rings.vtu", f, self.r_in + np.arange(self.n_rings + 1) * self.dr)


def block_error(blocks: np.ndarray) -> np.ndarray:
    """Standard error of the mean from block values [n_blocks, ...]: std (ddof 1) over the
    finite blocks / sqrt(their number); NaN where fewer than two are finite (a ring that is
    NaN in every block, e.g. without contacts)."""
    ok = np.isfinite(blocks)
    n = ok.sum(axis=0)
    filled = np.where(ok, blocks, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = filled.sum(axis=0) / n
        var = np.where(ok, (filled - mean) ** 2, 0.0).sum(axis=0) / (n - 1)
        return np.where(n >= 2, np.sqrt(var) / np.sqrt(n), np.nan)


def derived(s: np.ndarray, r: np.ndarray, dr: float, h: float, r_tilde: np.ndarray | None = None,
            k_n_2d: float = 1.0, wall_speed: float = 1.0) -> dict[str, np.ndarray]:
    """Continuum fields from (time-averaged) ring sums s [n_rings, N_COLUMNS]; k_n_2d = k'_n =
    k_n/h (N/m^2) and wall_speed = Omega R_i (m/s) set the paper's normalisations."""
    vol_ring = 2.0 * math.pi * h * r * dr
    with np.errstate(invalid="ignore", divide="ignore"):
        vol = s[:, COL["vol"]]
        out = {"nu": vol / vol_ring, "v_r": s[:, COL["mom_r"]] / vol,
               "v_phi": s[:, COL["mom_phi"]] / vol, "omega": s[:, COL["spin"]] / vol,
               "C": s[:, COL["coord"]] / vol,
               "C_number": s[:, COL["contacts"]] / s[:, COL["count"]]}
        fabric = _tensor(s, "fabric") / vol_ring[:, None, None]
        inv = _inverse(fabric)
        sigma = _tensor(s, "stress") / vol_ring[:, None, None]
        eps = (math.pi * h / vol_ring)[:, None, None] * _tensor(s, "deform") @ inv
        couple = s[:, [COL["couple_r"], COL["couple_phi"]]] / vol_ring[:, None]
        curv = (math.pi * h / vol_ring)[:, None] * np.einsum(
            "ka,kab->kb", s[:, [COL["curv_r"], COL["curv_phi"]]], inv)
    for name, t in (("F", fabric), ("sigma", sigma), ("eps", eps)):
        for a, ca in enumerate(("r", "phi")):
            for b, cb in enumerate(("r", "phi")):
                out[f"{name}_{ca}{cb}"] = t[:, a, b]
    out["M_zr"], out["M_zphi"] = couple[:, 0], couple[:, 1]
    out["kappa_zr"], out["kappa_zphi"] = curv[:, 0], curv[:, 1]
    for name, t in (("F", fabric), ("sigma", sigma), ("eps", eps)):
        tr, dev, angle = eigen(t)
        out[f"tr_{name}"], out[f"dev_{name}"], out[f"angle_{name}"] = tr, dev, angle
    with np.errstate(invalid="ignore", divide="ignore"):
        dv = np.gradient(out["v_phi"], r) if r.size > 1 else np.zeros_like(r)
        out["D_rphi"] = 0.5 * (dv - out["v_phi"] / r)
        out["W_rphi"] = 0.5 * (dv + out["v_phi"] / r)
        out["excess_spin"] = out["omega"] - out["W_rphi"]
        out["stiffness"] = 2.0 * math.pi / k_n_2d * out["tr_sigma"] / out["tr_eps"]
        out["shear_resistance"] = math.pi / k_n_2d * out["dev_sigma"] / out["dev_eps"]
        out["mu_c"] = np.abs(out["M_zr"]) / np.abs(out["kappa_zr"])
        out["mu_c_signed"] = out["M_zr"] / out["kappa_zr"]
        out["v_phi_norm"] = out["v_phi"] / wall_speed
        out["shear_torque"] = 2.0 * math.pi * h * r * r * out["sigma_phir"]
    if r_tilde is not None:
        v0, decay = exponential_fit(r_tilde, out["v_phi_norm"])
        out["fit_v0"], out["fit_s"] = np.array(v0), np.array(decay)
    return out


def eigen(t: np.ndarray):
    """Trace, deviator (T_max - T_min) and angle (deg, of the major eigenvector from e_r, in
    (-90, 90]) of the symmetric part of 2x2 tensors t [n,2,2]."""
    rr, pp = t[:, 0, 0], t[:, 1, 1]
    rp = 0.5 * (t[:, 0, 1] + t[:, 1, 0])
    half_diff = 0.5 * (rr - pp)
    radius = np.hypot(half_diff, rp)
    return rr + pp, 2.0 * radius, np.degrees(0.5 * np.arctan2(2.0 * rp, rr - pp))


def exponential_fit(r_tilde: np.ndarray, v: np.ndarray, lo: float = 0.25, hi: float = 8.1):
    """v = v0 exp(-r_tilde/s) by least squares of log v over lo <= r_tilde <= hi (the paper's
    range); NaN if fewer than 3 positive values."""
    sel = (r_tilde >= lo) & (r_tilde <= hi) & (v > 0) & np.isfinite(v)
    if sel.sum() < 3:
        return math.nan, math.nan
    slope, icpt = np.polyfit(r_tilde[sel], np.log(v[sel]), 1)
    return math.exp(icpt), -1.0 / slope if slope < 0 else math.inf


def _tensor(s: np.ndarray, name: str) -> np.ndarray:
    return np.stack([s[:, COL[f"{name}_rr"]], s[:, COL[f"{name}_rphi"]],
                     s[:, COL[f"{name}_phir"]], s[:, COL[f"{name}_phiphi"]]],
                    axis=-1).reshape(-1, 2, 2)


def _inverse(t: np.ndarray) -> np.ndarray:
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


def read_rings(run_dir: str | Path) -> dict[str, np.ndarray]:
    """Fields (with ``_err`` standard errors) from DIR/rings.h5, plus ``times`` and ``sums``."""
    with h5py.File(Path(run_dir) / "rings.h5", "r") as h5:
        out = {k: v[()] for k, v in h5["fields"].items()}
        out["times"] = h5["times"][()]
        out["sums"] = h5["sums"][()]
        if "inner_torque" in h5:  # files written before the torque was recorded lack it
            out["inner_torque_samples"] = h5["inner_torque"][()]
        if "reference_diameter" in h5.attrs:
            out["reference_diameter"] = float(h5.attrs["reference_diameter"])
        out["columns"] = tuple(h5["sums"].attrs["columns"].split(","))
    return out

"""Numbers that compare a run's ring averages with the paper (Lätzel, Luding, Herrmann).

Stage: averaging (validation). Every metric is computed from ``read_rings(DIR)`` and the run's
scene, and is defined here once; ``run_scripts/paper/paper_figures.py`` puts them in the comparison
table. Regions are in r~ = (r - R_i)/d~:

- fit_v0, fit_s: v_phi/(Omega R_i) = v0 exp(-r~/s) over 0.25 <= r~ <= 8.1 by least squares
  on v (the primary fit, docs/roughness.md); fit_v0_log, fit_s_log: a line through log v.
- dilation: nu_bulk = mean nu over 10 <= r~ <= 15 (the frozen outer packing, paper §1.4.1);
  deficit = nu_bulk - mean nu over 1 <= r~ <= 4; width = the r~ where nu, smoothed over one d~,
  first comes within 0.01 of nu_bulk (outside the first layer, r~ > 1).
- trF_over_nuC: mean and RMS deviation from 1 of tr F/(nu C_number) over the rings with
  contacts, C_number the contacts per particle (number-weighted, the paper's C; with the
  volume-weighted C of the sums, tr F = nu C is an identity).
- stiffness_excess: mean over the rings of (2 pi E/k'_n)/tr F - 1 in 1 <= r~ <= 15 (the
  paper: "the mean-field value underestimates the simulation data by some per cent").
- orientation: the angles of F, sigma, eps averaged over the inner ten layers (0.5 <= r~ <= 9)
  and the fraction of those rings where phi_F > phi_sigma > phi_eps (paper Fig. 1.4).
- torque balance: T(r) = 2 pi h r^2 sigma_phir over 1 <= r~ <= 15. Its mean and the error of
  that mean come from the per-sample sums (T averaged over the zone in every sample, then
  block errors over time: neighbouring rings share particles, so ring errors are not
  independent). Flatness is judged twice: ring by ring (d~/8) and in windows of one d~ (the
  particle-volume stress obeys the balance only up to O(d) structure, which does not average
  out in time in the frozen outer packing): chi^2/dof about the mean with block errors
  (about 1: flat within the errors) and the fraction within 2 errors. Compared with the
  torque of the inner ring on the particles, from its contacts.
  shear_torque_total_*: the same with the kinetic stress, 2 pi h r^2 (sigma + sigma_kin)_phir.
  bottom_torque_mean: the torque the bottom friction takes from the disks inside radius r,
  sum of mu_b m g r v_phi/|v| over the moving ones, from the snapshots in the averaging
  window, averaged over the same rings: in steady shear the inner ring's torque equals the
  torque through a ring plus this one (the body force of the momentum balance).
- ring loads (boundary.LOADS, each with its block error ``_err``): both rings' torques on the
  particles, the particles' forces on them and their radial push. Torque balance of the
  whole cell: torque_sum = T_in + T_out (torque_sum_err: the block error of its per-sample
  series), torque_imbalance = torque_sum / T_in, the wall shear stresses
  T_in/(2 pi h R_i^2) and -T_out/(2 pi h R_o^2); bottom_torque_cell (the bottom
  friction's torque on all free disks) and angular_momentum_rate (dL/dt of the free disks,
  from the first and last snapshot of the window; NaN without two), and
  torque_balance_residual = T_in + T_out - bottom_torque_cell - dL/dt (0 up to the noise of
  the time averages), torque_balance_relative = that over |T_in|.
- mu_c_outer: median of mu_c/k'_n over 4 <= r~ <= 15 (the paper: mu_c grows with density;
  the median, because kappa_zr passes through zero in some rings); mu_c_band: the same over
  0.5 <= r~ <= 3 (the paper: smaller in the dilute band than in the dense outer part).
- regime in the band (1 <= r~ <= 4) and the bulk (10 <= r~ <= 15): the inertial number I
  (median over the rings), contacts per disk, pressure with and without the kinetic part.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pardem.sampling import (FREE, load_scene, normal_stiffness, read_snapshots,
                             volume_fraction)

from .boundary import LOADS, torque_balance
from .derived import exponential_fit, log_exponential_fit
from .io import read_rings
from .timeavg import ERROR_BLOCKS, block_error

PAPER = {"A": {"v0": 0.670, "s": 1.662, "nu_bar": 0.8084},
         "B": {"v0": 0.756, "s": 1.584, "nu_bar": 0.8149},
         "C": {"v0": 0.788, "s": 1.191, "nu_bar": 0.8194}}


def global_volume_fraction(scene) -> float:
    """v-bar of SPEC §2: free disks plus half of every wall disk, over pi (R_o^2 - R_i^2)."""
    return volume_fraction(scene)


PAPER_SCENES = {f"couette-{k}": k for k in PAPER}
"""The shipped scenes that stand for the paper's simulations
(run_scripts/scenes/couette_[ABC].toml)."""


def load_run(run_dir: str | Path, label: str | None = None, paper: str | None = None) -> dict:
    """Ring fields of a folder with rings.h5 (a run folder, or its offline/ subfolder) plus the
    run's scene-derived constants (k'_n, h, d~, Omega R_i). ``label``: how figures name the run
    (default: its folder's name); ``paper``: the paper's simulation it stands for ("A", "B",
    "C"; default: only for the shipped scenes couette-A/B/C), which figures and tables compare
    it with. ``name`` is ``paper`` if set, else the label."""
    run_dir = Path(run_dir)
    rings = read_rings(run_dir)
    scene_file = run_dir / "scene.toml"
    scene = load_scene(scene_file if scene_file.exists() else run_dir.parent / "scene.toml")
    c, g = scene.contact, scene.geometry
    _, k_n, k_t = normal_stiffness(scene)
    d_ref = rings.get("reference_diameter",
                      (rings["r"][1] - rings["r"][0]) / (rings["r_tilde"][1] - rings["r_tilde"][0]))
    paper = paper or PAPER_SCENES.get(scene.info.name)
    if label is None:
        label = run_dir.parent.name if run_dir.name == "offline" else run_dir.name
    return {"dir": run_dir, "name": paper or label, "paper": paper, "label": label,
            "scene": scene.info.name, "rings": rings,
            "k_n_2d": k_n / c.height, "k_t": k_t, "height": c.height, "d_ref": d_ref,
            "wall_speed": g.omega_inner * g.inner_radius, "r_in": g.inner_radius,
            "r_out": g.outer_radius,
            "bottom": c.mu_bottom * c.gravity if scene.effects.bottom_friction else 0.0,
            "nu_bar": global_volume_fraction(scene), "n_samples": rings["times"].size,
            "window": (float(rings["times"][0]), float(rings["times"][-1]))}


def _region(f: dict, lo: float, hi: float) -> np.ndarray:
    return (f["r_tilde"] >= lo) & (f["r_tilde"] <= hi)


def _mean(values: np.ndarray, median: bool = False) -> float:
    """Mean (or median) of the finite values; NaN for a region the cell does not have."""
    values = values[np.isfinite(values)]
    if not values.size:
        return math.nan
    return float(np.median(values) if median else np.mean(values))


def metrics(run: dict) -> dict:
    f = run["rings"]
    # both fits from the profile (files written before the primary fit changed hold the log
    # fit under fit_v0)
    out = dict(zip(("fit_v0", "fit_s"), exponential_fit(f["r_tilde"], f["v_phi_norm"])))
    out.update(zip(("fit_v0_log", "fit_s_log"),
                   log_exponential_fit(f["r_tilde"], f["v_phi_norm"])))
    bulk = _mean(f["nu"][_region(f, 10, 15)])
    out["nu_bulk"] = bulk
    out["dilation_deficit"] = bulk - _mean(f["nu"][_region(f, 1, 4)])
    per_d = max(int(round(1.0 / (f["r_tilde"][1] - f["r_tilde"][0]))), 1)
    smooth = np.convolve(f["nu"], np.ones(per_d) / per_d, mode="same")
    recovered = np.flatnonzero((f["r_tilde"] > 1) & (smooth >= bulk - 0.01))
    out["dilation_width"] = float(f["r_tilde"][recovered[0]]) if recovered.size else math.nan
    has = f["C_number"] > 0
    ratio = f["tr_F"][has] / (f["nu"][has] * f["C_number"][has])
    out["trF_over_nuC"] = _mean(ratio)
    out["trF_over_nuC_rms"] = _mean((ratio - 1) ** 2) ** 0.5
    zone = _region(f, 1, 15) & (f["tr_F"] > 0)
    out["stiffness_excess"] = _mean(f["stiffness"][zone] / f["tr_F"][zone] - 1)
    inner = _region(f, 0.5, 9)
    for t in ("F", "sigma", "eps"):
        out[f"angle_{t}"] = _mean(f[f"angle_{t}"][inner])
    ordered = (f["angle_F"] > f["angle_sigma"]) & (f["angle_sigma"] > f["angle_eps"])
    out["ordering_fraction"] = _mean(ordered[inner].astype(float))
    zone = _region(f, 1, 15)
    per_ring = ring_torques(run)[:, zone]  # samples x rings
    per_window = np.array([w.mean(axis=1) for w in _windows(per_ring, 1.0 / _step(f))]).T
    mean, mean_err = block_mean(per_ring.mean(axis=1))
    out["shear_torque_mean"], out["shear_torque_mean_err"] = float(mean), float(mean_err)
    has_kinetic = "kin_rphi" in f["columns"]  # older files lack the kinetic sums
    kinetic = ring_torques(run, kinetic=True)[:, zone] if has_kinetic else np.nan
    total, total_err = block_mean((per_ring + kinetic).mean(axis=1))
    out["shear_torque_total_mean"] = float(total)
    out["shear_torque_total_mean_err"] = float(total_err)
    for label, series in (("", per_ring), ("_window", per_window)):
        values, errs = block_mean(series)
        dev = (values - values.mean()) / errs
        out[f"shear_torque_chi2{label}"] = float(np.sum(dev**2) / (dev.size - 1))
        out[f"shear_torque_within_2err{label}"] = float(np.mean(np.abs(dev) < 2))
    out["bottom_torque_mean"] = bottom_torque(run, f["r_tilde"][zone])
    out.update(ring_balance(run))
    mu = f["mu_c"][_region(f, 4, 15)] / run["k_n_2d"]
    out["mu_c_outer"] = _mean(mu, median=True)
    out["mu_c_band"] = _mean(f["mu_c"][_region(f, 0.5, 3)] / run["k_n_2d"], median=True)
    nan = np.full(f["r"].size, np.nan)
    for zone, (lo, hi) in (("band", (1, 4)), ("bulk", (10, 15))):
        sel = _region(f, lo, hi)
        out[f"inertial_number_{zone}"] = _mean(f.get("inertial_number", nan)[sel], median=True)
        out[f"contacts_per_disk_{zone}"] = _mean(f["C_number"][sel])
        out[f"pressure_{zone}"] = _mean(0.5 * f["tr_sigma"][sel])
        out[f"pressure_kin_{zone}"] = _mean(f.get("pressure_kin", nan)[sel])
    return out


def bottom_torque(run: dict, r_tilde: np.ndarray) -> float:
    """The bottom friction's torque (N m) on the free disks inside r~, mean over r_tilde and
    over the snapshots in the averaging window (NaN without snapshots; 0 without bottom
    friction). A disk at rest (|v| = 0) is held by static friction no larger than the
    sliding one and is left out."""
    if run["bottom"] == 0.0:
        return 0.0
    folder = run["dir"].parent if run["dir"].name == "offline" else run["dir"]
    if not (folder / "snapshots").is_dir():
        return math.nan
    lo, hi = run["window"]
    edges = run["r_in"] + np.asarray(r_tilde) * run["d_ref"]
    per_snapshot = []
    for snap in read_snapshots(folder):
        if not lo <= snap["time"] <= hi:
            continue
        free = snap["kind"] == FREE
        x, v, m = snap["position"][free], snap["velocity"][free], snap["mass"][free]
        r, speed = np.hypot(x[:, 0], x[:, 1]), np.hypot(v[:, 0], v[:, 1])
        moving = speed > 0
        torque = np.zeros(r.size)
        torque[moving] = (run["bottom"] * m[moving] * (x[moving, 0] * v[moving, 1]
                          - x[moving, 1] * v[moving, 0]) / speed[moving])  # mu_b g m r v_phi/|v|
        order = np.argsort(r)
        inside = np.searchsorted(r[order], edges, side="right")
        per_snapshot.append(np.concatenate([[0.0], np.cumsum(torque[order])])[inside].mean())
    return float(np.mean(per_snapshot)) if per_snapshot else math.nan


def ring_balance(run: dict) -> dict:
    """The ring loads with their errors and the cell's torque balance (module docstring)."""
    f, out = run["rings"], {}
    for name in LOADS:  # files written before the outer ring's loads were kept: NaN
        out[name] = float(f.get(name, math.nan))
        out[name + "_err"] = float(f.get(name + "_err", math.nan))
    out.update(torque_balance(out, run["r_in"], run["r_out"], run["height"]))
    loads = f["ring_loads_samples"]  # the sum's error from its own series (T_in, T_out correlate)
    series = loads[:, LOADS.index("inner_torque")] + loads[:, LOADS.index("outer_torque")]
    out["torque_sum_err"] = float(block_mean(series)[1]) if series.size else math.nan
    out["bottom_torque_cell"], out["angular_momentum_rate"] = cell_budget(run)
    residual = (out["torque_sum"] - out["bottom_torque_cell"] - out["angular_momentum_rate"])
    out["torque_balance_residual"] = residual
    out["torque_balance_relative"] = residual / abs(out["inner_torque"])
    return out


def cell_budget(run: dict) -> tuple[float, float]:
    """(the bottom friction's torque on all free disks, N m, mean over the snapshots in the
    averaging window; dL/dt of the free disks, N m, from the first and last of them), with L
    = sum m (x × v) + (m d^2/8) omega. NaN without snapshots (dL/dt: without two)."""
    folder = run["dir"].parent if run["dir"].name == "offline" else run["dir"]
    lo, hi = run["window"]
    snaps = [s for s in read_snapshots(folder) if lo <= s["time"] <= hi] if (
        folder / "snapshots").is_dir() else []
    if not snaps:
        return math.nan, math.nan
    bottom = bottom_torque(run, [(run["r_out"] - run["r_in"]) / run["d_ref"]])
    momenta = []
    for snap in (snaps[0], snaps[-1]):
        free = snap["kind"] == FREE
        x, v, m = snap["position"][free], snap["velocity"][free], snap["mass"][free]
        spin = m * (2 * snap["radius"][free]) ** 2 / 8 * snap["omega"][free]
        momenta.append(math.fsum(m * (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0])) + math.fsum(spin))
    span = snaps[-1]["time"] - snaps[0]["time"]
    return bottom, (momenta[1] - momenta[0]) / span if span > 0 else math.nan


def ring_torques(run: dict, kinetic: bool = False) -> np.ndarray:
    """T = 2 pi h r^2 sigma_phir (N m) of every sample and ring [samples, rings], from the raw
    sums (sigma_phir = stress_phir / V with V = 2 pi h r dr), as RingAverager's shear_torque;
    ``kinetic``: the kinetic stress's part instead, each sample's momentum flux about the
    window's mean flow u = <mmom>/<mass> (its time mean is the field sigma_kin_phir)."""
    f = run["rings"]
    s, col = f["sums"], f["columns"].index
    dr = f["r"][1] - f["r"][0]
    if not kinetic:
        return s[:, :, col("stress_phir")] * f["r"] / dr
    mass = s[:, :, col("mass")]
    with np.errstate(invalid="ignore", divide="ignore"):
        u_r, u_phi = (np.where(mass.mean(0) > 0, s[:, :, col(k)].mean(0) / mass.mean(0), 0.0)
                      for k in ("mmom_r", "mmom_phi"))
    flux = (s[:, :, col("kin_rphi")] - s[:, :, col("mmom_r")] * u_phi
            - s[:, :, col("mmom_phi")] * u_r + mass * u_r * u_phi)
    return flux * f["r"] / dr


def block_mean(series: np.ndarray):
    """Mean over the samples (axis 0) and its standard error from the same consecutive blocks
    as RingAverager.fields uses for every field."""
    parts = np.array([b.mean(axis=0) for b in
                      np.array_split(series, min(ERROR_BLOCKS, len(series)))])
    return series.mean(axis=0), block_error(parts)


def _step(f: dict) -> float:
    return float(f["r_tilde"][1] - f["r_tilde"][0])


def _windows(per_ring: np.ndarray, rings_per_window: float):
    n = max(int(round(rings_per_window)), 1)
    return [per_ring[:, k:k + n] for k in range(0, per_ring.shape[1] - n + 1, n)]

"""The paper's figures 1.2-1.9 (and two checks) as PNG files, from one or more run folders.

Stage: averaging output. ``make_figures(runs, out_dir)`` takes runs loaded by
``report.load_run`` (one run: ``pardem plot DIR``; the three paper runs:
``run_scripts/paper/paper_figures.py``) and writes, with the paper's axes and normalisations
(r~ = (r - R_i)/d~, k'_n = k_n/h) and error bars from the block errors of the samples:

    fig_1_2_volume_fraction.png    nu(r~)
    fig_1_3_velocity.png           v_phi/(Omega R_i), log scale, with the fits (ours, the paper's)
    fig_1_4_orientation.png        angles of F, sigma, eps, inner ten layers (B, or the run)
    fig_1_5_stiffness.png          2 pi E/k'_n against tr F, every ring, mean-field line
    fig_1_6_shear_resistance.png   pi G/k'_n against tr F, identity line
    fig_1_7_spin.png               omega and W_rphi (B), W_rphi of the fit; inset excess spin
    fig_1_8_couple_stress.png      M_zr/d~^2 and kappa_zr/d~^2 (B)
    fig_1_9_torque_resistance.png  mu_c/k'_n
    check_fabric_trace.png         tr F against nu C (C: contacts per particle)
    check_torque_balance.png       2 pi h r^2 sigma_phir per ring over the inner-ring torque
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .derived import exponential_fit, log_exponential_fit  # noqa: E402
from .report import PAPER  # noqa: E402

COLOURS = {"A": "tab:blue", "B": "tab:orange", "C": "tab:green"}
MARKERS = {"A": "o", "B": "s", "C": "^"}
FIT_RANGE = (0.25, 8.1)


def _style(run: dict, k: int) -> dict:
    paper = run.get("paper")
    return {"color": COLOURS.get(paper, f"C{k}"), "marker": MARKERS.get(paper, "o")}


def _label(run: dict) -> str:
    return f"{run['label']} (ν̄ = {run['nu_bar']:.4f})"  # nu-bar: the global volume fraction


def _focus(runs: list[dict]) -> dict:
    """The run of the single-simulation figures: B if present (as in the paper)."""
    return next((r for r in runs if r.get("paper") == "B"), runs[0])


def _r_max(runs: list[dict]) -> float:
    """The largest r~ of the runs' rings (the outer wall), plus a margin: axes follow the cell."""
    return 1.03 * max(float(np.nanmax(r["rings"]["r_tilde"])) for r in runs) + 0.2


def _fit_r(run: dict, n: int) -> np.ndarray:
    """r~ of the fit's range (0.25-8.1, the paper's), within the run's cell."""
    return np.linspace(FIT_RANGE[0], min(FIT_RANGE[1], float(np.nanmax(run["rings"]["r_tilde"]))),
                       n)


def _save(fig, out: Path, name: str) -> Path:
    path = out / name
    fig.tight_layout()
    fig.savefig(path.with_suffix(".png.tmp"), dpi=130, format="png")
    path.with_suffix(".png.tmp").replace(path)
    plt.close(fig)
    return path


def _errorbar(ax, x, y, err, run, k, **kw):
    st = _style(run, k)
    ax.errorbar(x, y, yerr=err, fmt=st["marker"], ms=3, lw=0.6, color=st["color"],
                label=kw.pop("label", _label(run)), **kw)


def volume_fraction(runs, out):
    fig, ax = plt.subplots(figsize=(6, 4))
    for k, run in enumerate(runs):
        f = run["rings"]
        _errorbar(ax, f["r_tilde"], f["nu"], f.get("nu_err"), run, k)
    ax.set(xlabel="r̃ = (r − R_i)/d̃", ylabel="volume fraction ν", ylim=(0.5, 1.0))
    ax.legend()
    return _save(fig, out, "fig_1_2_volume_fraction.png")


def velocity(runs, out):
    fig, ax = plt.subplots(figsize=(6, 4))
    for k, run in enumerate(runs):
        f, st, r = run["rings"], _style(run, k), _fit_r(run, 50)
        v, e = f["v_phi_norm"], f.get("v_phi_norm_err")
        ok = v > 0
        _errorbar(ax, f["r_tilde"][ok], v[ok], None if e is None else e[ok], run, k)
        v0, s = exponential_fit(f["r_tilde"], v)
        ax.plot(r, v0 * np.exp(-r / s), "-", color=st["color"],
                label=f"fit {run['label']}: v₀ = {v0:.3f}, s = {s:.3f}")
        v0, s = log_exponential_fit(f["r_tilde"], v)
        ax.plot(r, v0 * np.exp(-r / s), "--", lw=0.8, color=st["color"],
                label=f"log fit {run['label']}: v₀ = {v0:.3f}, s = {s:.3f}")
        if run.get("paper") in PAPER:
            p = PAPER[run["paper"]]
            ax.plot(r, p["v0"] * np.exp(-r / p["s"]), ":", color=st["color"],
                    label=f"paper {run['paper']}: v₀ = {p['v0']}, s = {p['s']}")
    ax.set(ylim=(1e-4, 2))  # fixed before the log scale: a run without flow has no data for it
    ax.set_yscale("log")
    ax.set(xlabel="r̃", ylabel="v_φ / (Ω R_i)", xlim=(0, _r_max(runs)))
    ax.legend(fontsize=7)
    return _save(fig, out, "fig_1_3_velocity.png")


def orientation(runs, out):
    run = _focus(runs)
    f = run["rings"]
    inner = (f["r_tilde"] >= 0) & (f["r_tilde"] <= 9.5)  # about ten layers
    fig, ax = plt.subplots(figsize=(6, 4))
    for t, fmt, label in (("F", "o", "fabric F"), ("sigma", "D", "stress σ"),
                          ("eps", "D", "elastic deformation gradient ε")):
        face = "none" if t == "sigma" else None
        ax.errorbar(f["r_tilde"][inner], f[f"angle_{t}"][inner],
                    yerr=f.get(f"angle_{t}_err", np.zeros_like(f["r"]))[inner], fmt=fmt, ms=3,
                    lw=0.5, mfc=face, label=label)
    ax.set(xlabel="r̃", ylabel="angle φ of the major eigenvector from e_r (deg)",
           title=f"simulation {run['label']}")
    ax.legend()
    return _save(fig, out, "fig_1_4_orientation.png")


def _markers(ax, runs, xy, ms=3.0):
    """Open markers of every run, at the points xy(run) -> (x, y)."""
    for k, run in enumerate(runs):
        st = _style(run, k)
        ax.plot(*xy(run), st["marker"], ms=ms, mfc="none", color=st["color"], label=_label(run))


def _against_trace(runs, key, ylabel, line_label):
    fig, ax = plt.subplots(figsize=(5.5, 4.5))

    def xy(run):
        f = run["rings"]
        ok = np.isfinite(f[key]) & (f["tr_F"] > 0)
        return f["tr_F"][ok], f[key][ok]

    _markers(ax, runs, xy)
    top = max((float(np.max(xy(r)[0])) for r in runs if xy(r)[0].size), default=0.0)
    low = min((float(np.min(xy(r)[0])) for r in runs if xy(r)[0].size), default=0.0)
    x = np.array([0.8 * low or 0.01 * top, top * 1.05 or 1.0])  # > 0: log axes in Fig. 1.6
    ax.plot(x, x, "k-", lw=1, label=line_label)
    ax.set(xlabel="tr F", ylabel=ylabel, xlim=(0, x[-1]))
    ax.legend(fontsize=8)
    return fig, ax


def stiffness(runs, out):
    fig, ax = _against_trace(runs, "stiffness", "2πĒ / k'_n = (2π/k'_n) tr σ / tr ε",
                             "mean field: 2πĒ/k'_n = tr F")
    ax.set_ylim(0, ax.get_xlim()[1] * 1.3)
    return _save(fig, out, "fig_1_5_stiffness.png")


def shear_resistance(runs, out):
    fig, ax = _against_trace(runs, "shear_resistance", "πG / k'_n = (π/k'_n) dev σ / dev ε",
                             "identity")
    ax.set_xscale("log")  # log-log: the identity stays a straight line
    ax.set_yscale("log")
    ax.set_xlim(ax.get_lines()[-1].get_xdata()[0], None)
    return _save(fig, out, "fig_1_6_shear_resistance.png")


def spin(runs, out):
    run = _focus(runs)
    f = run["rings"]
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.plot(f["r_tilde"], f["omega"], "-", color="k", lw=1, label="ω (particles)")
    ax.plot(f["r_tilde"], f["W_rphi"], "o", ms=2.5, color="tab:red", label="W_rφ (continuum)")
    r = np.linspace(*FIT_RANGE, 60)
    v0, s = exponential_fit(f["r_tilde"], f["v_phi_norm"])
    v = run["wall_speed"] * v0 * np.exp(-r / s)
    radius = run["r_in"] + r * run["d_ref"]
    # W = (dv/dr + v/r)/2 of the fitted profile, dv/dr = -v/(s d~)
    w_fit = 0.5 * v * (1.0 / radius - 1.0 / (s * run["d_ref"]))
    ax.plot(r, w_fit, ":", color="tab:red", label="W_rφ of the v_φ fit")
    ax.set(xlabel="r̃", ylabel="angular velocity (rad/s)", xlim=(0, min(12, _r_max([run]))),
           title=f"simulation {run['label']}")
    # below the axes: the curves fill the upper left, the inset the lower right
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3, fontsize=7)
    inset = ax.inset_axes([0.45, 0.25, 0.5, 0.35])
    for k, r_ in enumerate(runs):
        g = r_["rings"]
        inset.plot(g["r_tilde"], g["excess_spin"], "-", lw=0.8, color=_style(r_, k)["color"],
                   label=r_["label"])
    inset.axhline(0, color="grey", lw=0.5)
    inset.set_xlim(0, 8)
    inset.set_title("excess spin ω* = ω − W_rφ", fontsize=7)
    inset.tick_params(labelsize=6)
    inset.legend(fontsize=6)
    return _save(fig, out, "fig_1_7_spin.png")


def couple_stress(runs, out):
    run = _focus(runs)
    f, d2 = run["rings"], run["d_ref"] ** 2
    fig, (a, b) = plt.subplots(2, 1, figsize=(6, 6), sharex=True)
    for ax, key, label in ((a, "M_zr", "M_zr / d̃² (N/m³)"), (b, "kappa_zr", "κ_zr / d̃² (1/m)")):
        ax.errorbar(f["r_tilde"], f[key] / d2, yerr=f.get(f"{key}_err", 0 * f["r"]) / d2,
                    fmt="o", ms=2.5, lw=0.5)
        ax.axhline(0, color="grey", lw=0.5)
        ax.set(ylabel=label)
    a.set_title(f"simulation {run['label']}")
    b.set(xlabel="r̃", xlim=(0, _r_max([run])))
    return _save(fig, out, "fig_1_8_couple_stress.png")


def torque_resistance(runs, out):
    fig, ax = plt.subplots(figsize=(6, 4))

    def xy(run):  # mu_c = |M_zr|/|kappa_zr| >= 0; rings with mu_c = 0 or NaN have no log
        f = run["rings"]
        mu = f["mu_c"] / run["k_n_2d"]
        ok = np.isfinite(mu) & (mu > 0)
        return f["r_tilde"][ok], mu[ok]

    _markers(ax, runs, xy, ms=2.5)
    for k, run in enumerate(runs):  # the spring identity M = (k_t/pi h) kappa . F
        f = run["rings"]
        kf = f["kappa_zr"] * f["F_rr"] + f["kappa_zphi"] * f["F_phir"]
        pred = run["k_t"] / (math.pi * run["height"] * run["k_n_2d"]) * np.abs(kf / f["kappa_zr"])
        ok = np.isfinite(pred) & (pred > 0)
        ax.plot(f["r_tilde"][ok], pred[ok], "-", lw=0.7, color=_style(run, k)["color"],
                label=f"{run['label']}: (k_t/πh)|(κ·F)_r|/(k'_n|κ_zr|), the spring identity")
    ax.set(xlabel="r̃", ylabel="torque resistance μ_c / k'_n = |M_zr| / (k'_n |κ_zr|)",
           xlim=(0, _r_max(runs)))
    if any(xy(run)[1].size for run in runs):  # a log axis needs a positive value
        ax.set_yscale("log")
    else:
        ax.text(0.5, 0.5, "no ring with a finite, positive μ_c", transform=ax.transAxes,
                ha="center")
    ax.legend(fontsize=7)
    return _save(fig, out, "fig_1_9_torque_resistance.png")


def fabric_trace(runs, out):
    fig, ax = plt.subplots(figsize=(5, 4.5))
    _markers(ax, runs, lambda run: (run["rings"]["nu"] * run["rings"]["C_number"],
                                    run["rings"]["tr_F"]))
    lim = ax.get_xlim()
    ax.plot(lim, lim, "k-", lw=1, label="tr F = ν C")
    ax.set(xlabel="ν C (C: contacts per particle)", ylabel="tr F")
    ax.legend(fontsize=8)
    return _save(fig, out, "check_fabric_trace.png")


def torque_balance(runs, out):
    """Each run's torque through every ring relative to the torque its inner ring exerts (the
    runs' torques differ by orders of magnitude): 1 in steady state; the band is the inner
    ring's relative error; the dotted line the torque the outer ring takes back."""
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.axhline(1.0, color="k", lw=0.8)
    for k, run in enumerate(runs):
        f = run["rings"]
        st = _style(run, k)
        t, e = float(f["inner_torque"]), float(f.get("inner_torque_err", np.nan))
        if not (math.isfinite(t) and t != 0):  # e.g. averages taken before the shear began
            ax.plot([], [], " ", label=f"{run['label']}: no torque from the inner ring "
                    f"(T_inner = {t:.3g} N m), nothing to normalise by")
            continue
        err = f.get("shear_torque_err")
        _errorbar(ax, f["r_tilde"], f["shear_torque"] / t, None if err is None else err / abs(t),
                  run, k, label=f"{run['label']}: 2π h r² σ_φr / T_inner (T_inner = {t:.3g} N m)")
        if "shear_torque_total" in f:
            ax.plot(f["r_tilde"], f["shear_torque_total"] / t, "-", lw=0.7, color=st["color"],
                    label=f"{run['label']}: with the kinetic stress, 2π h r² (σ + σ_kin)_φr")
        ax.axhspan(1 - e / abs(t), 1 + e / abs(t), color=st["color"], alpha=0.2, lw=0)
        if math.isfinite(float(f.get("outer_torque", np.nan))):  # older files lack it
            ax.axhline(-float(f["outer_torque"]) / t, ls=":", lw=0.8, color=st["color"],
                       label=f"{run['label']}: torque the outer ring takes, −T_outer / T_inner")
    ax.set(xlabel="r̃", ylabel="torque through the ring / inner-ring torque",
           xlim=(0, _r_max(runs)), ylim=(-1, 3))
    ax.legend(fontsize=7)
    return _save(fig, out, "check_torque_balance.png")


FIGURES = (volume_fraction, velocity, orientation, stiffness, shear_resistance, spin,
           couple_stress, torque_resistance, fabric_trace, torque_balance)


def make_figures(runs: list[dict], out_dir: str | Path) -> list[Path]:
    """Every figure for the given runs (from ``report.load_run``) into out_dir."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return [fig(runs, out) for fig in FIGURES]

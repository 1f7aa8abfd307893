"""Every number or claim the paper states, against ours: one row each, with the seed mean ±
standard error and a verdict. Used by paper_figures.py for results/paper/comparison.md.

A number agrees when ours lies within 15 % of the paper's (``TOLERANCE``); a claim about a
trend or a sign agrees when it holds for the seed means and, where a difference decides it, by
more than two standard errors. The paper's numbers are the ones it prints (averaging/report.py
PAPER); its qualitative claims are quoted from its sections 1.4-1.6.
"""

from __future__ import annotations

import math

from averaging.report import PAPER

TOLERANCE = 0.15


def stat(groups: dict, name: str, key: str) -> tuple[float, float]:
    """(mean, standard error of the mean over the seeds; NaN for one seed) of a metric."""
    vals = [m[key] for m in groups[name]]
    mean = sum(vals) / len(vals)
    if len(vals) < 2:
        return mean, math.nan
    var = sum((v - mean) ** 2 for v in vals) / (len(vals) - 1)
    return mean, math.sqrt(var / len(vals))


def show(mean: float, err: float, digits: int = 3) -> str:
    if not math.isfinite(err):
        return f"{mean:.{digits}g}"
    return f"{mean:.{digits}g} ± {err:.1g}"


def _number_rows(groups: dict) -> list[tuple[str, str, str, str]]:
    rows = []
    for key, label in (("nu_bar", "global volume fraction v̄"), ("v0", "v₀ (primary fit)"),
                       ("s", "decay length s (primary fit)")):
        for name in groups:
            if name not in PAPER:
                continue
            paper = PAPER[name][key]
            metric = {"v0": "fit_v0", "s": "fit_s", "nu_bar": "nu_bar"}[key]
            mean, err = stat(groups, name, metric)
            off = mean / paper - 1
            verdict = "agree" if abs(off) <= TOLERANCE else f"differ ({100 * off:+.0f} %)"
            rows.append((f"{label}, {name}", show(mean, err, 4 if key == "nu_bar" else 3),
                         f"{paper}", verdict))
    return rows


def _trend(groups: dict, key: str, rising: bool) -> tuple[str, bool]:
    """The seed means of ``key`` in the order A, B, C and whether they rise (or fall)."""
    names = [n for n in ("A", "B", "C") if n in groups]
    means = [stat(groups, n, key) for n in names]
    ordered = all((b[0] > a[0]) == rising for a, b in zip(means, means[1:]))
    return (", ".join(f"{n} {show(*m)}" for n, m in zip(names, means)), ordered)


def _claim_rows(groups: dict) -> list[tuple[str, str, str, str]]:
    rows = []

    def each(key, test):
        """Per simulation: (text, holds) of test(mean, err)."""
        parts, ok = [], True
        for name in groups:
            mean, err = stat(groups, name, key)
            holds = test(mean, 0.0 if not math.isfinite(err) else err)
            ok &= holds
            parts.append(f"{name} {show(mean, err)}")
        return ", ".join(parts), ok

    text, ok = _trend(groups, "fit_s", rising=False)
    rows.append(("s falls with density (1.662 > 1.584 > 1.191)", text, "falls",
                 "agree" if ok else "differ"))
    text, ok = each("dilation_deficit", lambda m, e: m > 2 * e and m > 0)
    rows.append(("a dilated zone near the inner ring: ν(10–15) − ν(1–4) > 0", text, "> 0",
                 "agree" if ok else "differ"))
    text, ok = each("trF_over_nuC", lambda m, e: abs(m - 1) <= 0.05)
    rows.append(("tr F = νC \"with reasonable accuracy\" (mean of tr F/νC, within 5 %)", text,
                 "1", "agree" if ok else "differ"))
    text, ok = each("stiffness_excess", lambda m, e: 0 < m <= 0.1)
    rows.append(("stiffness above the mean-field line tr F \"by some per cent\" (0 to 10 %)",
                 text, "some %", "agree" if ok else "differ"))
    parts, ok = [], True
    for name in groups:
        f, s, e = (stat(groups, name, f"angle_{t}")[0] for t in ("F", "sigma", "eps"))
        ok &= f > s > e
        parts.append(f"{name} {f:.0f}°, {s:.0f}°, {e:.0f}°")
    rows.append(("fabric tilted more than stress, stress more than ε (φ_F > φ_σ > φ_ε)",
                 ", ".join(parts), "holds", "agree" if ok else "differ"))
    parts, ok = [], True
    for name in groups:
        t, te = stat(groups, name, "inner_torque")
        r, re = stat(groups, name, "shear_torque_total_mean")
        b = stat(groups, name, "bottom_torque_mean")[0]
        err = math.hypot(te if math.isfinite(te) else 0, re if math.isfinite(re) else 0)
        ok &= abs(t - r - b) <= 3 * err if err > 0 else False
        parts.append(f"{name} {r / t:.2f} + {b / t:.2f}" if t else f"{name} –")
    rows.append(("σ_rφ ∝ r⁻²: (torque through the rings, contacts and momentum flux, + the "
                 "bottom friction's inside them) / the inner ring's torque, within 3 errors",
                 ", ".join(parts), "1", "agree" if ok else "differ"))
    text, ok = _trend(groups, "mu_c_outer", rising=True)
    rows.append(("μ_c rises with density (outer part, μ_c/k'_n median 4 ≤ r̃ ≤ 15)", text,
                 "rises", "agree" if ok else "differ"))
    parts, ok = [], True
    for name in groups:
        band, outer = stat(groups, name, "mu_c_band")[0], stat(groups, name, "mu_c_outer")[0]
        ok &= band < outer
        parts.append(f"{name} {band:.3g} < {outer:.3g}")
    rows.append(("μ_c smaller in the dilute band than in the dense outer part", ", ".join(parts),
                 "holds", "agree" if ok else "differ"))
    return rows


def claim_table(groups: dict) -> list[str]:
    """Markdown lines: one row per number or claim; ``groups``: simulation -> list of the
    metrics (averaging/report.py) of its seeds."""
    lines = ["| the paper states | ours (seed mean ± standard error) | the paper | verdict |",
             "|---|---|---|---|"]
    for claim, ours, paper, verdict in _number_rows(groups) + _claim_rows(groups):
        lines.append(f"| {claim} | {ours} | {paper} | {verdict} |")
    return lines

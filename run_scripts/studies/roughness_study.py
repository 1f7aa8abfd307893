"""Wall roughness study: which layout of the paper's glued wall disks, by a rule fixed before the
runs, and what the layout changes (v0, wall slip, jamming); then the paper's claims without
figures. Results: docs/roughness.md and docs/roughness/*.png, one small JSON per run in
docs/roughness/runs/.

    python run_scripts/studies/roughness_study.py [--runs runs/roughness] [--jobs 2] [--ranks 1]
                                                  [--stage layouts|picked|claims|all]
                                                  [--report-only]

Stages: ``layouts`` runs simulation B with every admitted layout and the control, 3 seeds
each; ``picked`` runs A, B and C with the layout the rule (RULE below, applied by ``pick``)
selects from the finished layout runs; ``claims`` runs the paper's claims without figures
(4 k_n; neither bottom nor tangential friction; Omega = 0). Every run is
``pardem run SCENE --out RUNS/NAME`` with the full protocol (239 s, averages 180-239 s). The
script is resumable: a run whose JSON exists is skipped, and an interrupted run continues from
its checkpoint (which carries the ring samples taken so far), so an interrupted study continues
where it stopped; raw run folders (~0.3 GB each) stay in RUNS, outside git. ``--jobs``
concurrent runs of ``--ranks`` ranks each (on 2 cores: 2 jobs of 1 rank).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import study_runs  # noqa: E402
from roughness_claims import CLAIMS, claims_section  # noqa: E402
from study_runs import (DOCS, MEASURES, ROOT, SEEDS, TABLES, measure_rows,  # noqa: E402
                        rows_of, run_one, seed_stats, wall_fraction)

from averaging.report import PAPER  # noqa: E402
from pardem.boundaries.walls import wall_layout  # noqa: E402

WALL_FRACTION = (0.0047, 0.00005)  # the paper's v-bar_wall and the admitted tolerance

LAYOUTS = {
    "both-7mm": ({"inner_wall_count": 93, "outer_wall_count": 227},
                 "93 inner + 227 outer, 7.0 mm apart on both rings, flat surfaces behind "
                 "(pardem's first reconstruction)"),
    "split": ({"inner_wall_count": 160, "outer_wall_count": 159},
              "160 inner (4.06 mm apart) + 159 outer (9.98 mm apart), flat surfaces behind"),
    "inner-only": ({"inner_wall_count": 319, "outer_wall_count": 0},
                   "319 overlapping disks on the inner ring (2.04 mm apart), smooth outer ring"),
    "outer-only": ({"inner_wall_count": 0, "outer_wall_count": 319},
                   "smooth inner ring, 319 disks on the outer ring (4.97 mm apart)"),
    "both-7mm-bare": ({"inner_wall_count": 93, "outer_wall_count": 227,
                       "inner_flat_surface": False, "outer_flat_surface": False},
                      "control: as both-7mm without the flat surfaces behind the disks"),
}

CONTROLS = ("both-7mm-bare",)

PRIOR_ORDER = ("both-7mm", "split", "inner-only", "outer-only")

RULE = """\
Written before any layout run, and applied by `pick()` in `run_scripts/studies/roughness_study.py`.

1. **Admitted layouts.** Wall disks of d_w = 2.5 mm (Table 1.1) whose half areas give
   v̄_wall = 0.0047 ± 0.00005 (the paper's only statement about them): `both-7mm`, `split`,
   `inner-only`, `outer-only`. `both-7mm-bare` is a control (is it the flat surface behind the
   disks that locks the first layer?) and is never picked.
2. **Qualitative tests from the paper's text and figures, not its fitted numbers.** Each on
   the mean of 3 seeds of simulation B, with the seed scatter:
   - (a) *a shear band localised at the inner ring*: v_φ/(ΩR_i) decays exponentially over
     r̃ = 0.25–8.1, i.e. the median |ln(v/fit)| over that range is below ln 1.5;
   - (b) *a dilated zone near the inner wheel* (§1.4.1): ν(10 ≤ r̃ ≤ 15) − ν(1 ≤ r̃ ≤ 4) > 0
     by more than twice its seed standard error;
   - (c) *the first layer moves slower than the wall*: every fit of Fig. 1.3 starts below 1,
     so the log-fit v₀ must be below 1 by more than twice its seed standard error. This is the
     sign of a feature of the figure (wall slip), not a target value.
   A layout that fails any test is discarded.
3. **Choice among the survivors.** The first survivor in the order `both-7mm` (the same
   spacing on both rings, the fewest assumptions), `split` (both rings rough, equal counts),
   `inner-only`, `outer-only` (one ring smooth) is picked.
4. **No survivor:** keep `both-7mm` and say which test every layout failed.
5. **Reported either way:** if the survivors' v₀ (or all admitted layouts' v₀) bracket the
   paper's 0.756 for B, the paper's description does not determine v₀, and this document
   says so; the pick is not changed towards the paper's number.
"""


def scene_for(sim: str, layout: str, seed: int, **changes):
    """Simulation sim (A, B, C) with one of LAYOUTS and a seed (study_runs.scene_for)."""
    return study_runs.scene_for(sim, layout, seed, LAYOUTS[layout][0], **changes)


def tests(rows: list[dict]) -> dict:
    """The qualitative tests (a)-(c) of RULE on one layout's B runs: name -> (passed, text)."""
    res, _ = seed_stats(rows, "fit_log_residual")
    dil, dil_err = seed_stats(rows, "dilation_deficit")
    v0, v0_err = seed_stats(rows, "fit_v0")
    return {"a": (res < math.log(1.5), f"median |ln(v/fit)| = {res:.3f} (< {math.log(1.5):.3f})"),
            "b": (dil > 2 * dil_err, f"dilation {dil:.4f} ± {dil_err:.4f}"),
            "c": (v0 < 1 - 2 * v0_err, f"v0 = {v0:.3f} ± {v0_err:.3f}")}

def pick(results: dict[str, list[dict]]) -> tuple[str, str]:
    """The layout RULE selects from the finished B runs (name -> rows), and why."""
    survivors = [name for name in PRIOR_ORDER
                 if results.get(name) and all(ok for ok, _ in tests(results[name]).values())]
    if survivors:
        return survivors[0], f"survivors (in the rule's order): {', '.join(survivors)}"
    return "both-7mm", "no layout passed every test; the rule keeps both-7mm"

HEADER_LINES = 6
"""report_lines()' title and introduction, before which calibration_study.py puts its part."""

def report_lines() -> list[str]:
    """The layout study's part of docs/roughness.md (calibration_study.write_doc writes it),
    and its figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figs = DOCS / "roughness"
    figs.mkdir(parents=True, exist_ok=True)
    results = {name: rows_of(f"{name}-B") for name in LAYOUTS}
    done = {k: v for k, v in results.items() if v}
    lines = ["# Wall roughness: which layout of the glued wall disks, and what it changes", "",
             "Generated by `run_scripts/studies/calibration_study.py` and `roughness_study.py` "
             "from "
             "the run tables in `docs/roughness/runs/` (one JSON per run); do not edit by "
             "hand.", "",
             "The paper fixes only the wall disks' diameter (2.5 mm) and their share of the "
             "global volume fraction, v̄_wall = 0.0047 (half of each disk counted), about 319 "
             "disks in all; it does not say how they are shared between the rings, nor whether "
             "the flat ring surface behind them is a contact surface. These layouts satisfy "
             "that constraint; each is simulation B, the full protocol (239 s, averages "
             "180–239 s), 3 seeds, values as seed mean ± standard error of that mean.", "",
             "## The layout study: the decision rule", "", RULE, "## Layouts", "",
             "| layout | wall disks (inner + outer) | v̄_wall | description |",
             "|---|---|---|---|"]
    for name, (keys, text) in LAYOUTS.items():
        sc = scene_for("B", name, 1)
        g = sc.geometry
        lines.append(f"| `{name}` | {wall_layout(g, 'inner').count} + "
                     f"{wall_layout(g, 'outer').count} | {wall_fraction(sc):.5f} | {text} |")
    lines += ["", "## Results (simulation B)", "",
              "| measure | " + " | ".join(f"`{n}`" for n in done) + " |",
              "|---|" + "---|" * len(done)]
    lines += measure_rows(MEASURES, list(done.values()))
    lines.append("| runs finished | " + " | ".join(str(len(r)) for r in done.values()) + " |")
    lines += ["", f"The paper's B: v₀ = {PAPER['B']['v0']}, s = {PAPER['B']['s']}.", "",
              "## The rule applied", ""]
    complete = all(len(results[n]) == len(SEEDS) for n in PRIOR_ORDER)
    for name in PRIOR_ORDER:
        if len(results[name]) < 2:
            lines.append(f"- `{name}`: {len(results[name])} seed(s) finished, not judged yet")
        else:
            t = tests(results[name])
            lines.append(f"- `{name}`: " + "; ".join(
                f"({k}) {'pass' if ok else 'FAIL'}: {text}" for k, (ok, text) in t.items()))
    if complete:
        chosen, why = pick(results)
        v0s = [seed_stats(results[n], "fit_v0")[0] for n in PRIOR_ORDER]
        lines += ["", f"**Picked: `{chosen}`** ({why})."]
        if min(v0s) < PAPER["B"]["v0"] < max(v0s):
            lines.append(f"The admitted layouts' v₀ range from {min(v0s):.3f} to {max(v0s):.3f} "
                         f"and bracket the paper's {PAPER['B']['v0']}: the paper's description "
                         "of its walls does not determine v₀.")
        lines += picked_section(chosen)
    else:
        lines += ["", "The layout runs are not all finished; the rule is applied when they are."]
    lines += ["", "## What the contact displacement Δ changes", ""]
    lines += displacement_section([row for rows in done.values() for row in rows])
    lines += ["", "## Claims of the paper without figures", ""]
    lines += claims_section(pick(results)[0] if complete else None)
    lines += ["", "## Runs", "",
              "Wall times of runs made two at a time on the 2 cores of a shared machine; a run "
              "that was paused (while the test suite had the cores) lists the pause, excluded "
              "from its wall time; a run continued from its checkpoint lists that time.", "",
              "| run | command | ranks | wall time (s) | paused (s) | continued from t (s) |",
              "|---|---|---|---|---|---|"]
    for p in sorted(TABLES.glob("*.json")):
        row = json.loads(p.read_text())
        paused, since = row.get("paused_s"), row.get("restarted_from_s")
        lines.append(f"| {row['name']} | `{row['command']}` | {row['ranks']} | "
                     f"{row['wall_s'] - (paused or 0):.0f} | {paused or ''} | "
                     f"{'' if since is None else f'{since:.1f}'} |")
    plot_profiles(done, figs, plt)
    return lines

def plot_profiles(done: dict, figs: Path, plt) -> None:
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for k, (name, rows) in enumerate(done.items()):
        r = np.array(rows[0]["profile"]["r_tilde"])
        v = np.mean([row["profile"]["v_phi_norm"] for row in rows], axis=0)
        nu = np.mean([row["profile"]["nu"] for row in rows], axis=0)
        ax[0].semilogy(r, np.where(v > 0, v, np.nan), ".", ms=3, color=f"C{k}", label=name)
        ax[1].plot(r, nu, "-", lw=0.8, color=f"C{k}", label=name)
    r = np.linspace(0.25, 8.1, 50)
    ax[0].semilogy(r, PAPER["B"]["v0"] * np.exp(-r / PAPER["B"]["s"]), "k--", lw=1,
                   label="paper's fit (B)")
    ax[0].set(xlabel="r̃ = (r − R_i)/d̃", ylabel="v_φ/(ΩR_i)", xlim=(0, 15), ylim=(1e-4, 2),
              title="velocity, simulation B, seed mean")
    ax[1].set(xlabel="r̃", ylabel="ν", xlim=(0, 15), ylim=(0.5, 1.0),
              title="volume fraction, simulation B, seed mean")
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(figs / "layouts_B.png", dpi=120)
    plt.close(fig)

def displacement_section(rows: list[dict]) -> list[str]:
    """The paper's eta against the spring in Delta, over every finished B run (all layouts)."""
    rows = [r for r in rows if "stiffness_excess_spring" in r]
    if not rows:
        return ["No run measured yet."]

    def span(key, digits, scale=1.0):
        vals = [scale * r[key] for r in rows]
        return f"{min(vals):.{digits}f}–{max(vals):.{digits}f}"

    return [f"Offline averages of the same snapshots of the {len(rows)} finished B runs (every "
            "layout), once with Δ = δn − η (the paper's eq. 1.3, the default) and once with "
            "Δ = δn − ξ (the spring); ranges over the runs:", "",
            "| | Δ with η | Δ with the spring ξ | the paper |", "|---|---|---|---|",
            f"| (2πĒ/k'_n)/tr F − 1, 1 ≤ r̃ ≤ 15 | {span('stiffness_excess_eta', 3)} | "
            f"{span('stiffness_excess_spring', 3)} | \"some per cent\" above (Fig. 1.5) |",
            f"| (πG/k'_n)/tr F, 1 ≤ r̃ ≤ 4 | {span('shear_resistance_over_trF_eta', 3)} | "
            f"{span('shear_resistance_over_trF_spring', 3)} | near the identity line (Fig. 1.6) |",
            f"| dev ε, 1 ≤ r̃ ≤ 4 | {span('dev_eps_band_eta', 5)} | "
            f"{span('dev_eps_band_spring', 5)} | |",
            f"| μ_c/k'_n, median 4 ≤ r̃ ≤ 15 | {span('mu_c_outer_eta', 4)} | "
            f"{span('mu_c_outer_spring', 4)} | |",
            f"| mean \\|η\\|, mean \\|ξ\\| of the contacts at t = 239 s (µm) | "
            f"{span('mean_eta', 3, 1e6)} | {span('mean_spring', 3, 1e6)} | |",
            f"| mean overlap δ of the contacts at t = 239 s (µm) | "
            f"{span('mean_overlap', 3, 1e6)} | | |", "",
            "With η, the slip accumulated by sliding contacts (on average many times the "
            "overlaps and the springs) dominates the tangential part of Δ: ε's deviator grows "
            "by orders of magnitude, the shear resistance falls far below the identity line of "
            "Fig. 1.6, the stiffness departs from the mean-field line of Fig. 1.5 by far more "
            "than the paper's \"some per cent\" (in either direction), and κ grows so that "
            "μ_c falls by two orders of magnitude or more. With the spring, Figs. 1.5 "
            "and 1.6 are reproduced, but M = (k_t/πh) κ·F holds identically and μ_c restates "
            "the fabric. So the paper's figures 1.5 and 1.6 point to a Δ whose tangential part "
            "stays elastic (bounded by the Coulomb cap), not to the ever-growing η of its "
            "eq. 1.3; which one its Figs. 1.8–1.9 used cannot be told from the text."]

PICKED_MEASURES = [next(m for m in MEASURES if m[0] == key) for key in (
    "fit_v0", "fit_s", "first_layer_speed", "dilation_deficit", "trF_bulk",
    "contacts_per_disk_bulk", "stiffness_excess", "mu_c_outer")]

def picked_section(chosen: str) -> list[str]:
    """The picked layout on simulations A, B and C: seed mean ± standard error."""
    rows = {sim: rows_of(f"{chosen}-{sim}") for sim in ("A", "B", "C")}
    out = ["", "## The picked layout on A, B and C", "",
           f"`{chosen}`, the full protocol; seed mean ± standard error of that mean (a single "
           "value where one seed has finished).", "",
           "| measure | A | B | C |", "|---|---|---|---|"]
    out += measure_rows(PICKED_MEASURES, list(rows.values()))
    out.append("| seeds finished | " + " | ".join(str(len(r)) for r in rows.values()) + " |")
    out.append("| the paper's v₀ / s | " + " | ".join(
        f"{PAPER[sim]['v0']} / {PAPER[sim]['s']}" for sim in rows) + " |")
    return out

def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=Path, default=ROOT / "runs" / "roughness")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--stage", choices=["layouts", "picked", "claims", "all"], default="all")
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--remeasure", action="store_true",
                    help="recompute the measures of every finished run still in RUNS (keeps "
                         "each table's command and wall time), then write the report")
    args = ap.parse_args(argv)
    if args.remeasure:
        study_runs.remeasure(args.runs)
        args.report_only = True
    for name in LAYOUTS:  # the admission test of RULE 1, before anything runs
        frac = wall_fraction(scene_for("B", name, 1))
        if abs(frac - WALL_FRACTION[0]) > WALL_FRACTION[1]:
            raise SystemExit(f"layout {name}: v_bar_wall = {frac:.5f} is not admitted")
    if not args.report_only:
        jobs = []
        if args.stage in ("layouts", "all"):
            jobs += [(f"{n}-B-s{s}", scene_for("B", n, s)) for s in SEEDS for n in LAYOUTS]
        with ThreadPoolExecutor(args.jobs) as pool:
            list(pool.map(lambda j: run_one(*j, args.runs, args.ranks), jobs))
        results = {name: rows_of(f"{name}-B") for name in LAYOUTS}
        ready = all(len(results[n]) == len(SEEDS) for n in PRIOR_ORDER)
        if args.stage in ("picked", "claims", "all") and not ready:
            print("layout runs incomplete: the rule cannot pick yet", flush=True)
            return 1
        chosen = pick(results)[0] if ready else None
        jobs = []
        if args.stage in ("picked", "all"):
            jobs += [(f"{chosen}-{x}-s{s}", scene_for(x, chosen, s))
                     for s in SEEDS for x in ("A", "C")]
        if args.stage in ("claims", "all"):
            jobs += [(name, scene_for("B", chosen, 1, **changes))
                     for name, (changes, _) in CLAIMS.items()]
        with ThreadPoolExecutor(args.jobs) as pool:
            list(pool.map(lambda j: run_one(*j, args.runs, args.ranks), jobs))
    print("the runs' tables are in docs/roughness/runs/; docs/roughness.md: python "
          "run_scripts/studies/calibration_study.py --report-only", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

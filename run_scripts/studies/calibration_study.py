"""One wall parameter calibrated on simulation B's v0 alone, by rules written before the runs
(FIT_RULE, CALIBRATION_RULE, REGIME_RULE below, printed in docs/roughness.md); then A and C
with that value as predictions, and the runs that show what moves the flow regime.

    python run_scripts/studies/calibration_study.py [--runs runs/roughness] [--jobs 2] [--ranks 1]
                                                    [--stage calibrate|predict|regime|all]
                                                    [--report-only]

Stages: ``calibrate`` bisects the inner ring's wall-disk count N_in on B (3 seeds per value)
until the rule stops; ``predict`` runs A and C (3 seeds) with the calibrated N_in; ``regime``
runs B with it once per change of REGIME. Resumable from what is committed: the per-run JSON
summaries in docs/roughness/runs/ decide which value comes next and which runs are done; a run
folder in RUNS interrupted mid-run continues from its checkpoint (roughness_study.run_one).
Writes docs/roughness.md (these sections, then the layout study of roughness_study.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "run_scripts" / "studies"))

import roughness_study  # noqa: E402
import study_runs as rs  # noqa: E402  (the runs and their tables)
from averaging.report import PAPER  # noqa: E402

TARGET = PAPER["B"]["v0"]
WALL_DISKS = 319  # v-bar_wall = 0.0047 with d_w = 2.5 mm (SPEC §2)
START = {93: "both-7mm-B", 160: "split-B"}  # finished layout runs that start the bracket
MAX_NEW_VALUES = 4
PRIMARY = ("lin_v0", "lin_s")  # keys of the primary fit in the run tables
SECONDARY = ("fit_v0", "fit_s")  # the log fit

FIT_RULE = """\
Written before the calibration runs below (the git history shows the order) and not revised
by their outcome.

**Primary fit.** v_φ/(ΩR_i) = v₀ exp(−r̃/s) by ordinary least squares on v_φ/(ΩR_i) itself,
every ring (width d_small/8) one point of equal weight, over the rings whose centres lie in
0.25 ≤ r̃ ≤ 8.1; r̃ = (r − R_i)/d̃ with R_i the inner ring line (the wall disks' centres) and
d̃ = 8.00 mm (Table 1.1). Why this one:

1. The paper names the function it fitted, "v_φ(r) = v₀ exp(−r̃/s)", and the range,
   "r̃ = 0.25 to 8.1"; it names no transformation of the data. A least-squares fit of the
   stated function to the data is the literal reading; a straight line through ln v is a
   different error model (multiplicative noise).
2. A ring's v_φ is a time average of fluctuating disk velocities: its error does not shrink
   with v, so the relative error grows along the band. An unweighted fit of ln v gives a ring
   the weight 1/v² relative to the linear fit: the creep tail (v ≈ 2·10⁻³ at r̃ ≈ 8 in C)
   then counts ~10⁵ times as much as the rings at the wall, where v₀ is decided. The paper
   itself ends the band "before the velocity v_φ reaches the noise level", i.e. it did not
   mean the tail to decide the fit.
3. Fig. 1.3 shows the data on a log axis to show that the profile is exponential; a log axis
   does not say how the lines were fitted.

**Secondary fit, reported beside it everywhere:** a straight line through ln(v_φ/(ΩR_i)),
unweighted, same rings (rings with v ≤ 0 left out), as pardem's earlier tables used.
Both are computed by `averaging/report.py`.
"""

CALIBRATION_RULE = f"""\
Written before the calibration runs, applied by `next_value()` in
`run_scripts/studies/calibration_study.py`.

1. **The one free parameter**: N_in, the number of wall disks (d_w = 2.5 mm, centres on the
   ring line, flat ring surfaces behind them, as in `split`) glued to the inner ring; the outer
   ring takes {WALL_DISKS} − N_in, so v̄_wall = 0.0047 for every N_in. Nothing else differs from
   `couette_B.toml`.
2. **Target**: the paper's v₀ = {TARGET} of B, by the primary fit, as the mean of seeds 1–3,
   with the standard error of that mean from the seed scatter.
3. **Bracket**: the finished layout runs start it: N_in = 93 (`both-7mm`, 227 outer disks,
   v̄_wall 0.00471) and N_in = 160 (`split`).
4. **Step** (regula falsi): the next N_in interpolates the two bracket ends' mean v₀ linearly
   to {TARGET}, rounded to the nearest integer and kept strictly inside the bracket; its three
   seeds run; it replaces the bracket end on its side of {TARGET}.
5. **Stop**: at the first new N_in whose mean v₀ is within one standard error of {TARGET};
   else when the bracket ends are at most 2 disks apart or {MAX_NEW_VALUES} new values have
   run, the tested N_in with the smallest |v₀ − {TARGET}|/standard error.
6. **Then**: A and C, seeds 1–3, with that N_in unchanged. B's s and A's and C's v₀ and s are
   predictions, reported against the paper whatever they come out to. Nothing else is tuned
   towards the paper.
"""

# name -> (label, changes {table: {key: value}}) of B with the calibrated N_in, seed 1
REGIME = {
    "halfomega": ("Ω/2, twice as long (equal strain; averages 360–478 s)",
                  {"geometry": {"omega_inner": 0.05}, "time": {"end": 478.0},
                   "averaging": {"start": 360.0, "end": 478.0, "sample_interval": 0.2}}),
    "bottom10": ("bottom friction × 10", {"contact": {"mu_bottom": 2e-4}}),
    "mix5050": ("50:50 mixture by number at B's free area (1266 small + 1266 large)",
                {"species": ({"count": 1266}, {"count": 1266})}),
}
REGIME_RULE = """\
Written before these runs: simulation B with the calibrated N_in, seed 1, one change each,
the full protocol; reported: v₀ and s (both fits), the inertial number I, contacts per disk,
pressure and ψ₆ of the small disks in the band (1 ≤ r̃ ≤ 4) and the bulk (10 ≤ r̃ ≤ 15).
The changes: """ + "; ".join(label for label, _ in REGIME.values()) + """; and the
compression first, the inner ring starting to turn only when it ends (t = 2 s; this needs a
start time for the ring's rotation, which the scene does not have yet). No run of this list
feeds back into the calibration.
"""


def nin_walls(n: int) -> dict:
    return {"inner_wall_count": n, "outer_wall_count": WALL_DISKS - n}


def cal_name(n: int, sim: str = "B") -> str:
    return f"cal-N{n}-{sim}"


def points() -> dict[int, tuple[float, float, int]]:
    """N_in -> (mean primary v0, its standard error, seeds finished) of B, from the tables."""
    out = {}
    for n, prefix in START.items():
        rows = rs.rows_of(prefix)
        out[n] = (*rs.seed_stats(rows, PRIMARY[0]), len(rows))
    for table in rs.TABLES.glob("cal-N*-B-s*.json"):
        n = int(table.name.split("-")[1][1:])
        rows = rs.rows_of(cal_name(n))
        out[n] = (*rs.seed_stats(rows, PRIMARY[0]), len(rows))
    return out


def next_value(pts: dict) -> tuple[int | None, int | None, str]:
    """CALIBRATION_RULE: (N_in to run next or None, the chosen N_in or None, why)."""
    done = {n: p for n, p in pts.items() if p[2] == len(rs.SEEDS)}
    pending = [n for n, p in pts.items() if p[2] < len(rs.SEEDS)]
    if pending:
        return min(pending), None, f"N_in = {min(pending)} has seeds left to run"
    new = [n for n in sorted(done) if n not in START]
    for n in new:
        v0, err, _ = done[n]
        if abs(v0 - TARGET) <= err:
            return None, n, f"N_in = {n}: v₀ = {v0:.3f} ± {err:.3f} is within one error"
    above = [n for n in done if done[n][0] > TARGET]  # v0 falls as N_in grows
    below = [n for n in done if done[n][0] <= TARGET]
    lo, hi = max(above), min(m for m in below if m > max(above))
    if hi - lo <= 2 or len(new) >= MAX_NEW_VALUES:
        best = min(done, key=lambda n: abs(done[n][0] - TARGET) / done[n][1])
        return None, best, (f"bracket {lo}–{hi} closed after {len(new)} new value(s): the "
                            f"closest in errors is N_in = {best}")
    (v_lo, _, _), (v_hi, _, _) = done[lo], done[hi]
    n = round(lo + (v_lo - TARGET) / (v_lo - v_hi) * (hi - lo))
    n = min(max(n, lo + 1), hi - 1)
    return n, None, f"bracket {lo} ({v_lo:.3f}) – {hi} ({v_hi:.3f}): next N_in = {n}"


def run_all(jobs: list, args) -> None:
    with ThreadPoolExecutor(args.jobs) as pool:
        list(pool.map(lambda j: rs.run_one(*j, args.runs, args.ranks), jobs))


def calibrate(args) -> int | None:
    """Runs the rule to its end (or until a run fails); returns the chosen N_in."""
    while True:
        n, chosen, why = next_value(points())
        print(f"[calibration] {why}", flush=True)
        if chosen is not None:
            return chosen
        todo = [(f"{cal_name(n)}-s{s}", rs.scene_for("B", cal_name(n), s, nin_walls(n)))
                for s in rs.SEEDS if not (rs.TABLES / f"{cal_name(n)}-s{s}.json").exists()]
        run_all(todo, args)
        write_doc()
        if len(rs.rows_of(cal_name(n))) < len(rs.SEEDS):
            print("[calibration] a run failed; stopping", flush=True)
            return None


def predictions(n: int, args) -> None:
    run_all([(f"{cal_name(n, sim)}-s{s}", rs.scene_for(sim, cal_name(n, sim), s,
                                                     nin_walls(n)))
             for s in rs.SEEDS for sim in ("A", "C")], args)


def regime(n: int, args) -> None:
    jobs = []
    for key, (_, changes) in REGIME.items():
        species = changes.get("species")
        plain = {k: v for k, v in changes.items() if k != "species"}
        scene = rs.scene_for("B", f"regime-{key}", 1, nin_walls(n), **plain)
        if species:
            scene = dataclasses.replace(scene, species=tuple(
                dataclasses.replace(sp, **c) for sp, c in zip(scene.species, species)))
        jobs.append((f"regime-{key}-N{n}", scene))
    run_all(jobs, args)


# ---------------------------------------------------------------- the document

def calibration_lines() -> list[str]:
    pts = points()
    out = ["## The velocity fit", "", FIT_RULE, "## Calibrating the wall layout on B", "",
           CALIBRATION_RULE, "| N_in (inner + outer) | seeds | v₀ primary (linear) | s primary | "
           "v₀ (log fit) | s (log fit) |", "|---|---|---|---|---|---|"]
    for n in sorted(pts):
        rows = rs.rows_of(START.get(n, cal_name(n)))
        outer = 227 if n == 93 else WALL_DISKS - n
        out.append(f"| {n} + {outer} | {len(rows)} | " + " | ".join(
            rs.fmt(rows, k) for k in PRIMARY + SECONDARY) + " |")
    _, chosen, why = next_value(pts)
    out += ["", f"The rule: {why}.", ""]
    if chosen is not None:
        out += prediction_lines(chosen)
    out += ["## What moves the regime", "", REGIME_RULE]
    if chosen is not None:
        out += regime_lines(chosen)
    return out


REGIME_MEASURES = [("lin_v0", "v₀ primary", 3), ("lin_s", "s primary", 3),
                   ("fit_v0", "v₀ log fit", 3), ("fit_s", "s log fit", 3),
                   ("I_band", "inertial number I, 1 ≤ r̃ ≤ 4 (median)", 4),
                   ("I_bulk", "I, 10 ≤ r̃ ≤ 15", 5),
                   ("contacts_band", "contacts per disk, 1 ≤ r̃ ≤ 4", 2),
                   ("contacts_bulk", "contacts per disk, 10 ≤ r̃ ≤ 15", 2),
                   ("p_band", "pressure ½tr σ, 1 ≤ r̃ ≤ 4 (N/m²)", 4),
                   ("p_bulk", "pressure, 10 ≤ r̃ ≤ 15 (N/m²)", 4),
                   ("p_kin_band", "kinetic pressure, 1 ≤ r̃ ≤ 4 (N/m²)", 5),
                   ("psi6_band", "ψ₆ of the small disks, 1 ≤ r̃ ≤ 4", 3),
                   ("psi6_bulk", "ψ₆, 10 ≤ r̃ ≤ 15", 3)]


def regime_lines(n: int) -> list[str]:
    """B with the calibrated N_in (its seeds) beside the one-change runs of REGIME."""
    base = rs.rows_of(START[n] if n in START else cal_name(n))
    runs = {key: rs.claim_rows(f"regime-{key}-N{n}") for key in REGIME}
    if not any(runs.values()):
        return ["Not run yet (stage `regime`).", ""]
    heads = [f"B, N_in = {n} ({len(base)} seeds)"] + [label for label, _ in REGIME.values()]
    out = ["| measure | " + " | ".join(heads) + " |", "|---" * (len(heads) + 1) + "|"]
    out += rs.measure_rows([m for m in REGIME_MEASURES
                            if any(m[0] in r for rows in [base, *runs.values()] for r in rows)],
                           [base] + list(runs.values()))
    return out + [""]


def prediction_lines(n: int) -> list[str]:
    groups = {sim: rs.rows_of(START[n] if sim == "B" and n in START else cal_name(n, sim))
              for sim in ("A", "B", "C")}
    out = [f"**Calibrated: N_in = {n}.** A and C with it are predictions:", "",
           "| | A | B | C |", "|---|---|---|---|"]
    for key, label in (("lin_v0", "v₀ primary"), ("lin_s", "s primary"),
                       ("fit_v0", "v₀ log fit"), ("fit_s", "s log fit")):
        out.append(f"| {label} | " + " | ".join(rs.fmt(r, key) for r in groups.values()) + " |")
    out.append("| the paper's v₀ / s | " + " | ".join(
        f"{PAPER[s]['v0']} / {PAPER[s]['s']}" for s in groups) + " |")
    out.append("| seeds finished | " + " | ".join(str(len(r)) for r in groups.values()) + " |")
    return out + [""]


def write_doc() -> None:
    lines = roughness_study.report_lines()
    head, rest = lines[:roughness_study.HEADER_LINES], lines[roughness_study.HEADER_LINES:]
    text = "\n".join(head + calibration_lines() + rest) + "\n"
    tmp = rs.DOCS / "roughness.md.tmp"
    tmp.write_text(text)
    tmp.replace(rs.DOCS / "roughness.md")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=Path, default=ROOT / "runs" / "roughness")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--stage", choices=["calibrate", "predict", "regime", "all"], default="all")
    ap.add_argument("--report-only", action="store_true")
    args = ap.parse_args(argv)
    if not args.report_only:
        chosen = calibrate(args)
        if chosen is not None and args.stage in ("predict", "all"):
            predictions(chosen, args)
        if chosen is not None and args.stage in ("regime", "all"):
            regime(chosen, args)
    write_doc()
    print(f"wrote {rs.DOCS / 'roughness.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

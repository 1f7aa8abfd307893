"""What accuracy costs in time: measured tables and plots for the time step, the integrator, the
neighbour skin, the ring averaging (width x weighting), the sampling interval and the ranks.

    python run_scripts/studies/accuracy_study.py [--run runs/paper/B] [--out docs] [--quick]

Writes OUT/accuracy.md (every table generated here), OUT/accuracy/*.png and
OUT/accuracy/results.json. The averaging and sampling sections read a finished run with
snapshots and in-situ samples (--run, default runs/paper/B; without one, the small cell of
the time-step section is used). --quick runs every section on tiny inputs in about a minute
(the test suite does this, so the script cannot rot); the full study takes about an hour on 2
cores and is run by hand, its output committed. Timings are medians and single-core unless a
row says otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
import accuracy_measures as am  # noqa: E402
from accuracy_stability import stability_line, stability_section  # noqa: E402

INTEGRATORS = ("verlet", "verlet-halfstep")
FULL = {"dt": [12, 20, 50, 100, 200], "phases": 8, "gas_time": 0.2, "seeds": (5, 6),
        "couette_end": 4.0, "skins": [0.025, 0.05, 0.1, 0.2, 0.4], "cost_steps": 4000,
        "repeats": 3, "widths": [1 / 32, 1 / 16, 1 / 8, 1 / 5, 1 / 4, 1 / 2, 1, 2],
        "snapshots": 60, "intervals": [0.1, 0.2, 0.5, 1.0, 2.0, 5.0], "ranks": [1, 2, 3, 4],
        "rank_steps": 20000}
QUICK = {"dt": [20, 50], "phases": 2, "gas_time": 0.02, "seeds": (5,), "couette_end": 0.3,
         "skins": [0.05, 0.1], "cost_steps": 200, "repeats": 1, "widths": [1 / 8, 1],
         "snapshots": 5, "intervals": [0.01, 0.02], "ranks": [], "rank_steps": 0}
WEIGHTINGS = ("centre", "slice", "exact", "gaussian")


def order(x: list[float], err: list[float]) -> list[float]:
    """Local orders of convergence between successive rows (x = steps per contact)."""
    return [math.log(err[k] / err[k + 1]) / math.log(x[k + 1] / x[k])
            if err[k] > 0 and err[k + 1] > 0 else math.nan for k in range(len(x) - 1)]


def table(header: list[str], rows: list[list]) -> list[str]:
    def cell(v):
        if isinstance(v, float):
            return "–" if math.isnan(v) else (f"{v:.3g}" if abs(v) < 1e4 else f"{v:.3e}")
        return str(v)
    return (["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
            + ["| " + " | ".join(cell(v) for v in r) + " |" for r in rows] + [""])


class Study:
    def __init__(self, p: dict, out: Path, run: Path | None, quick: bool):
        self.p, self.out, self.run, self.quick = p, out, run, quick
        self.fig_dir = out / "accuracy"
        self.fig_dir.mkdir(parents=True, exist_ok=True)
        self.md: list[str] = []
        self.results: dict = {}
        self.tmp = Path(tempfile.mkdtemp(prefix="pardem-accuracy-"))

    def figure(self, fig, name: str) -> str:
        fig.tight_layout()
        fig.savefig(self.fig_dir / name, dpi=110)
        plt.close(fig)
        return f"![{name}](accuracy/{name})"

    # -- 1 and 2: time step and integrator ---------------------------------------------------
    def time_step(self):
        p, md = self.p, self.md
        ns = p["dt"]
        res = {}
        for integ in INTEGRATORS:
            col = [am.collision_errors(n, integ, p["phases"]) for n in ns]
            gas = [am.energy_error(n, integ, p["gas_time"], p["seeds"]) for n in ns]
            prof = [am.couette_profiles(n, integ, p["couette_end"]) for n in ns]
            res[integ] = {"collision": col, "gas": gas, "profiles": prof}
        ref = res["verlet"]["profiles"][-1]  # finest dt, default integrator
        noise_nu = float(np.sqrt(np.nanmean(ref["nu_err"] ** 2)))
        noise_v = float(np.sqrt(np.nanmean(ref["v_err"] ** 2)))
        md += ["## 1. Time step and integrator", "",
               "dt = t_c/N with t_c = 2.177 ms (two small disks). Collision errors are the worst "
               f"over {p['phases']} phases of contact start between two steps (analytic "
               "reference); the elastic gas is 250 disks between fixed rings with every "
               f"dissipative effect off (relative energy deviation over {p['gas_time']} s); the "
               f"Couette profiles are ν and v_φ/(ΩR_i) of a small sheared cell ({p['couette_end']}"
               " s, second half averaged, rings of d̃/2), as the RMS difference from the finest "
               "dt of the default integrator, in units of the block error of one run "
               f"(RMS: ν {noise_nu:.2g}, v_φ/(ΩR_i) {noise_v:.2g}). Two runs that differ in any "
               "bit end in different packings, and the block error of one run does not see that "
               "run-to-run scatter: two independent runs differ by ≈ 1.4 block errors only if "
               "their packings rearrange fully, which the frozen outer region never does. A "
               "time-step effect would show as a trend with dt. The cost column is the wall time "
               "per simulated second of the paper cell (couette_B after compression, one core).",
               ""]
        ckpt = am.compressed_paper_cell(self.tmp / "compressed.h5")
        cost = {integ: [am.step_cost(ckpt, n, integrator=integ, steps=p["cost_steps"],
                                     repeats=p["repeats"]) for n in ns] for integ in INTEGRATORS}
        rows, dev = [], {integ: [] for integ in INTEGRATORS}
        for integ in INTEGRATORS:
            r = res[integ]
            for k, n in enumerate(ns):
                pr = r["profiles"][k]
                d_nu = float(np.sqrt(np.nanmean((pr["nu"] - ref["nu"]) ** 2))) / noise_nu
                d_v = float(np.sqrt(np.nanmean((pr["v"] - ref["v"]) ** 2))) / noise_v
                dev[integ].append((d_nu, d_v))
                rows.append([integ, f"t_c/{n}", r["collision"][k]["t_c"],
                             r["collision"][k]["e_n"], r["gas"][k]["worst"],
                             "ref" if (integ == "verlet" and k == len(ns) - 1) else d_nu,
                             "ref" if (integ == "verlet" and k == len(ns) - 1) else d_v,
                             cost[integ][k]["wall_per_sim_s"]])
        md += table(["integrator", "dt", "err t_c", "err e_n", "energy err (gas)",
                     "Δν / noise", "Δv_φ / noise", "wall s per simulated s"], rows)
        for integ in INTEGRATORS:
            r = res[integ]
            o_t = order(ns, [c["t_c"] for c in r["collision"]])
            o_e = order(ns, [c["e_n"] for c in r["collision"]])
            o_g = order(ns, [g["mean"] for g in r["gas"]])
            md.append(f"- {integ}: local orders of t_c {np.round(o_t, 2).tolist()}, e_n "
                      f"{np.round(o_e, 2).tolist()}, gas energy (mean deviation) "
                      f"{np.round(o_g, 2).tolist()}.")
        md += ["", "Theory: velocity Verlet is second order for smooth forces, which the t_c "
               "errors of the default integrator show. The half-step scheme evaluates the "
               "damping and the spring increment half a step late, a first-order error in every "
               "contact: first order in t_c and e_n. e_n of the default lies between first and "
               "second order: what remains comes from the steps in which a contact begins or "
               "ends, where the force is not smooth (the window weighting removes its leading "
               "part). The gas energy has no velocity-dependent force, so both integrators give "
               "the same numbers; single halvings scatter (a chaotic gas), around order 2.", ""]
        fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        for integ, ls in zip(INTEGRATORS, ("-o", "--s")):
            r = res[integ]
            ax[0].loglog(ns, [c["t_c"] for c in r["collision"]], ls, label=f"t_c, {integ}")
            ax[0].loglog(ns, [c["e_n"] for c in r["collision"]], ls, label=f"e_n, {integ}")
            ax[1].loglog(ns, [g["mean"] for g in r["gas"]], ls, label=f"gas energy, {integ}")
        for a in ax:
            a.set_xlabel("N = t_c / dt")
            a.legend(fontsize=7)
        ax[0].set_ylabel("worst relative error (two-disk collision)")
        ax[1].set_ylabel("mean relative energy deviation")
        md += [self.figure(fig, "time_step.png"), ""]
        self.results["time_step"] = {
            "N": ns, **{integ: {"collision": res[integ]["collision"], "gas": res[integ]["gas"],
                                "cost": cost[integ], "profile_dev": dev[integ]}
                        for integ in INTEGRATORS}}
        return cost

    # -- 3: skin --------------------------------------------------------------------------------
    def skin(self):
        p = self.p
        ckpt = am.compressed_paper_cell(self.tmp / "compressed.h5")
        rows, res = [], []
        for s in p["skins"]:
            c = am.step_cost(ckpt, skin_d=s, steps=p["cost_steps"], repeats=p["repeats"])
            res.append(c)
            rows.append([f"{s} d", c["pairs"], c["rebuilds_per_1000"], 1e6 * c["step_s"],
                         c["mps"]])
        self.md += ["## 2. Neighbour skin", "",
                    "Verlet-list skin in small-particle diameters, on the compressed paper cell "
                    "(one core): listed pairs, neighbour builds per 1000 steps, time per step "
                    "(all stages) and flow-particle-steps per second.", ""]
        self.md += table(["skin", "pairs", "builds / 1000 steps", "µs / step", "M / s"], rows)
        self.results["skin"] = {"skins": p["skins"], "rows": res}

    # -- 4: averaging ----------------------------------------------------------------------------
    def averaging(self, run: Path):
        p, d = self.p, am.D_S
        widths = [w * d for w in p["widths"]]
        g = am.averaging_grid(run, widths, list(WEIGHTINGS), p["snapshots"])
        grid = g["grid"]
        fine = grid[("exact", widths[0])]
        rows, res = [], {}
        for w in WEIGHTINGS:
            for dr, frac in zip(widths, p["widths"]):
                c = grid[(w, dr)]
                ex = grid[("exact", dr)]
                bias = float(np.sqrt(np.mean((c["nu"] - ex["nu"]) ** 2)))
                # departure from the finest exact profile, read at this width's ring centres,
                # in the layered zone next to the inner ring (r~ < 5)
                zone = c["r_tilde"] < 5
                ref_at = np.interp(c["r"][zone], fine["r"], fine["nu"])
                depart = float(np.sqrt(np.mean((c["nu"][zone] - ref_at) ** 2)))
                noise = float(np.nanmedian(c["nu_err"]))
                res[f"{w} {frac:.4g}"] = {"bias": bias, "departure": depart, "noise": noise,
                                          "cost": c["cost"]}
                rows.append([w, f"d/{1 / frac:.3g}" if frac < 1 else f"{frac:g} d", bias,
                             depart, noise, 1e3 * c["cost"]])
        self.md += ["## 3. Ring averaging: width × weighting", "",
                    f"ν from {g['samples']} snapshots of `{run}` (t = {g['window'][0]:.0f}–"
                    f"{g['window'][1]:.0f} s), d = d_small. *bias*: RMS difference from the "
                    "exact disk–ring overlap at the same width (what the weighting itself "
                    "costs); *departure*: RMS difference, at this width's ring centres in the "
                    "layered zone r̃ < 5, from the finest exact profile (what the width costs: "
                    "the paper's 'discretization effects'); *noise*: median block error of a "
                    "ring; *cost*: one sample on one core.", ""]
        self.md += table(["weighting", "Δr", "bias", "departure", "noise", "ms / sample"], rows)
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        for w, ls in zip(WEIGHTINGS, ("-o", "-s", "-^", "-v")):
            ax[0].loglog(p["widths"], [res[f"{w} {f:.4g}"]["departure"] for f in p["widths"]],
                         ls, label=w)
        ax[0].loglog(p["widths"], [res[f"slice {f:.4g}"]["noise"] for f in p["widths"]], "k:",
                     label="noise (slice)")
        ax[0].axvspan(1 / 5, 1, color="grey", alpha=0.15, lw=0)
        ax[0].set(xlabel="Δr / d", ylabel="departure of ν from the finest exact profile")
        ax[0].legend(fontsize=7)
        for frac in p["widths"]:
            c = grid[("slice", frac * d)]
            ax[1].plot(c["r_tilde"], c["nu"], "-", lw=0.8, label=f"slice, Δr = {frac:.3g} d")
        ax[1].set(xlabel="r̃", ylabel="ν", xlim=(0, 5))
        ax[1].legend(fontsize=6)
        self.md += [self.figure(fig, "averaging.png"), ""]
        self.results["averaging"] = res

    # -- 5: sampling -----------------------------------------------------------------------------
    def sampling(self, run: Path):
        s = am.sampling(run, self.p["intervals"])
        self.md += ["## 4. Sampling interval and number of samples", "",
                    f"From the in-situ samples of `{run}` ({s['n']} samples every {s['dt']:.3g} s"
                    f", T = {s['T']:.3g} s): v_φ/(ΩR_i) of the shear zone (1 ≤ r̃ ≤ 3) and tr σ "
                    "of the bulk (5 ≤ r̃ ≤ 15). τ is the integrated autocorrelation time; the "
                    "error of the time average when sampling every Δt is measured (8 blocks) "
                    "and modelled, σ √(max(2τ, Δt)/T).", ""]
        rows = []
        for name in ("v_phi", "tr_sigma"):
            q = s[name]
            for r in q["rows"]:
                rows.append([name, f"{q['tau']:.3g} s", r["interval"], r["samples"],
                             r["err"] / abs(q["mean"]), r["err_model"] / abs(q["mean"])])
        self.md += table(["quantity", "τ", "Δt (s)", "samples", "rel. error (blocks)",
                          "rel. error (model)"], rows)
        fig, ax = plt.subplots(figsize=(6, 4))
        for name in ("v_phi", "tr_sigma"):
            rho = s[name]["rho"]
            ax.plot(np.arange(rho.size) * s["dt"], rho, label=f"{name}: τ = {s[name]['tau']:.2g} s")
        ax.axhline(0, color="grey", lw=0.5)
        ax.set(xlabel="lag (s)", ylabel="autocorrelation")
        ax.legend()
        self.md += [self.figure(fig, "sampling.png"), ""]
        self.results["sampling"] = {k: (v if not isinstance(v, dict) else
                                        {kk: vv for kk, vv in v.items() if kk != "rho"})
                                    for k, v in s.items()}
        return s

    # -- 6: ranks --------------------------------------------------------------------------------
    def ranks(self):
        p = self.p
        med = am.throughput_by_ranks(p["ranks"], p["rank_steps"], p["repeats"])
        rows = [[r, m / 1e6, m / med[1] if 1 in med else math.nan,
                 "yes" if r > 2 else "no"] for r, m in med.items()]
        self.md += ["## 5. Ranks", "",
                    "couette_B after compression, `run_scripts/benchmarks/bench.py` (median of "
                    f"{p['repeats']} runs of {p['rank_steps']} steps); this machine has 2 cores, "
                    "so 3 and 4 ranks are oversubscribed (correctness only).", ""]
        self.md += table(["ranks", "M flow-particle-steps / s", "speed-up", "oversubscribed"],
                         rows)
        self.results["ranks"] = {str(k): v for k, v in med.items()}

    def defaults(self):
        """Section 0, from the measured rows (each default names the numbers behind it)."""
        r, md = self.results, ["## 0. Defaults and why", ""]
        if "time_step" in r:
            t = r["time_step"]
            ns = t["N"]
            k50 = ns.index(50) if 50 in ns else len(ns) - 1
            v, hs = t["verlet"], t["verlet-halfstep"]
            md.append(
                f"- **dt = t_c/{ns[k50]}** (`dt_per_contact = 50`): two-disk errors "
                f"{v['collision'][k50]['t_c']:.1e} (t_c) and {v['collision'][k50]['e_n']:.1e} "
                f"(e_n), elastic-gas energy {v['gas'][k50]['worst']:.1e}; its Couette profiles "
                f"differ from the finest dt's by {v['profile_dev'][k50][0]:.1f} (ν) and "
                f"{v['profile_dev'][k50][1]:.1f} (v_φ) block errors, t_c/{ns[-2]} by "
                f"{v['profile_dev'][-2][0]:.1f} and {v['profile_dev'][-2][1]:.1f}: run-to-run "
                f"scatter, no trend with dt (table 1); {v['cost'][k50]['wall_per_sim_s']:.3g} s "
                f"per simulated second against {v['cost'][-1]['wall_per_sim_s']:.3g} s at "
                f"t_c/{ns[-1]}; t_c/{ns[0]} takes {v['cost'][0]['wall_per_sim_s']:.3g} s but "
                f"misses e_n by {v['collision'][0]['e_n']:.1e}.")
            extra = 100 * (v['cost'][k50]['step_s'] / hs['cost'][k50]['step_s'] - 1)
            md.append(
                f"- **integrator = \"verlet\"** (predicted velocities + damping window): at "
                f"t_c/{ns[k50]} its e_n error is {v['collision'][k50]['e_n']:.1e} against "
                f"{hs['collision'][k50]['e_n']:.1e} for the plain half-step Verlet of LAMMPS "
                f"GRANULAR, for {extra:+.0f} % of the time per step; its orders in table 1.")
            md.append(stability_line(ns))
        if "skin" in r:
            rows = r["skin"]["rows"]
            best = min(range(len(rows)), key=lambda k: rows[k]["step_s"])
            k = r["skin"]["skins"].index(0.1) if 0.1 in r["skin"]["skins"] else best
            md.append(f"- **skin = 0.1 d** (`skin = \"auto\"`): {1e6 * rows[k]['step_s']:.0f} µs "
                      f"per step against {1e6 * rows[best]['step_s']:.0f} µs for the fastest "
                      f"({r['skin']['skins'][best]} d); builds are cheap (table 3), so the choice "
                      "matters little; the smaller pair list also keeps memory low.")
        if "averaging" in r:
            a = r["averaging"]

            def get(w, frac):
                return a.get(f"{w} {frac:.4g}", {})
            s8, e8 = get("slice", 1 / 8), get("exact", 1 / 8)
            md.append(
                f"- **ring width d_small/8, slice weighting** (the paper's): at d/8 the slice "
                f"bias is {s8.get('bias', math.nan):.1e}, the departure from the finest profile "
                f"{s8.get('departure', math.nan):.1e}, the noise {s8.get('noise', math.nan):.1e}; "
                f"one sample costs {1e3 * s8.get('cost', math.nan):.2g} ms "
                f"(exact: {1e3 * e8.get('cost', math.nan):.2g} ms). Table 4 shows where the "
                "departure rises above the noise (the paper's discretization effects) and why "
                "'centre' is unusable below one diameter.")
        if "sampling" in r:
            sv, st = r["sampling"]["v_phi"], r["sampling"]["tr_sigma"]
            cost = r["sampling"].get("in_situ_cost")
            spent = (f"in the run a sample cost {1e3 * cost[0]:.2g} ms, {100 * cost[1]:.2g} % of "
                     "its wall time" if cost else "a sample costs a few ms")
            md.append(
                f"- **sample_interval = 0.1 s**: the autocorrelation times are "
                f"{sv['tau']:.2g} s (v_φ, shear zone) and {st['tau']:.2g} s (tr σ, bulk), so "
                "0.1 s oversamples about tenfold: the error of the average is the same from "
                "0.1 s to 2 s within the ±25 % scatter of an 8-block estimate, as the model "
                "predicts up to Δt ≈ 2τ (table 5). Coarser sampling would save almost nothing: "
                f"{spent}. Short runs (T of a few τ) need every sample they can get.")
        md.append("")
        self.md[4:4] = md

    def write(self):
        self.md += stability_section(self.fig_dir / "stability.json")
        (self.out / "accuracy.md").write_text("\n".join(self.md) + "\n")
        (self.fig_dir / "results.json").write_text(json.dumps(self.results, indent=1,
                                                              default=_plain))


def _plain(v):
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    raise TypeError(type(v))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("runs/paper/B"))
    ap.add_argument("--out", type=Path, default=Path("docs"))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--sections", nargs="*", default=["dt", "skin", "averaging", "sampling",
                                                      "ranks"])
    args = ap.parse_args(argv)
    study = Study(QUICK if args.quick else FULL, args.out, args.run, args.quick)
    run = args.run if (args.run / "rings.h5").exists() else None
    if run is None and ({"averaging", "sampling"} & set(args.sections)):
        run = small_run(study.tmp / "small")
    study.md += header(args, run)
    if "dt" in args.sections:
        study.time_step()
    if "skin" in args.sections:
        study.skin()
    if "averaging" in args.sections:
        study.averaging(run)
    if "sampling" in args.sections:
        study.sampling(run)
    if "ranks" in args.sections and study.p["ranks"]:
        study.ranks()
    study.defaults()
    study.write()
    print(args.out / "accuracy.md")
    return 0


def header(args, run) -> list[str]:
    return ["# What accuracy costs in time", "",
            "Generated by `python run_scripts/studies/accuracy_study.py"
            + (" --quick" if args.quick else "") + f"` (averaging and sampling from `{run}`). "
            "Section 0 names the defaults we ship and the rows that justify them.", ""]


def small_run(out: Path) -> Path:
    """A small sheared cell with snapshots and in-situ samples (when no paper run exists)."""
    from pardem.input.schema import scene_from_dict
    from pardem.simulation import Simulation

    scene = scene_from_dict({
        "scene": {"name": "small", "kind": "couette", "seed": 3}, "geometry": am.SMALL_CELL,
        "species": [{"name": "small", "diameter": am.D_S, "mass": am.M_S, "count": 260},
                    {"name": "large", "diameter": 8.99e-3, "mass": 0.490e-3, "count": 40}],
        "time": {"end": 0.4}, "output": {"snapshot_interval": 0.02},
        "averaging": {"start": 0.2, "end": 0.4, "sample_interval": 0.01,
                      "reference_diameter": 8e-3}})
    Simulation(scene, out_dir=out).run(progress=False)
    return out


if __name__ == "__main__":
    sys.exit(main())

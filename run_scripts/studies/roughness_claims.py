"""The paper's claims without figures, each a run of B with the picked layout and one change
(roughness_study.py runs them): the table and the paragraphs of docs/roughness.md."""

from __future__ import annotations

from study_runs import MEASURES, claim_rows, measure_rows, rows_of, seed_stats


CLAIMS = {
    "claim-kn4": ({"contact": {"k_n": 4 * 352.1}}, "k_n × 4"),
    "claim-nofriction": ({"effects": {"tangential_friction": False, "bottom_friction": False}},
                         "neither bottom nor tangential friction"),
    "claim-noshear": ({"geometry": {"omega_inner": 0.0}}, "Ω = 0 (no shear)"),
}

CLAIM_MEASURES = [next(m for m in MEASURES if m[0] == key) for key in (
    "stiffness_excess_spring", "stiffness_excess", "stiffness_excess_eta", "trF_bulk",
    "contacts_per_disk_bulk", "M_zr_band", "M_zr_outer_rms", "M_zr_outer_within_2err",
    "fit_v0")]

def claims_section(chosen: str | None) -> list[str]:
    """The claim runs (simulation B with the picked layout, seed 1, one change each) beside
    the picked layout's B seeds (mean ± standard error): the numbers the paragraphs cite."""
    runs = {name: claim_rows(name) for name in CLAIMS}
    if not any(runs.values()) or chosen is None:
        return ["Not run yet (stage `claims`)."]
    base = rows_of(f"{chosen}-B")
    heads = [f"B, `{chosen}` ({len(base)} seeds)"] + [label for _, label in CLAIMS.values()]
    out = ["Simulation B with the picked layout and seed 1, one change each, full protocol; "
           f"beside them the {len(base)} seeds of B (mean ± standard error).", "",
           "| measure | " + " | ".join(heads) + " |", "|---" * (len(heads) + 1) + "|"]
    out += measure_rows(CLAIM_MEASURES, [base] + list(runs.values()))
    if not all(runs.values()):
        return out
    return out + [""] + claim_paragraphs(base, runs)

def claim_paragraphs(base: list[dict], runs: dict[str, list[dict]]) -> list[str]:
    """One paragraph per claim. The numbers come from the runs; the reading of them was
    written once all three had finished."""
    kn4, free, still = (runs[n][0] for n in CLAIMS)
    b = {k: seed_stats(base, k) for k in ("stiffness_excess_spring", "stiffness_excess",
                                          "trF_bulk", "contacts_per_disk_bulk",
                                          "pressure_bulk", "M_zr_band", "M_zr_outer_rms",
                                          "M_zr_outer_within_2err")}
    ratio = b["M_zr_band"][0] / b["M_zr_outer_rms"][0]
    return [
        "**Stiffness for k_n × 4 (Fig. 1.5's collapse).** Normalised by its own k'_n, the "
        f"stiffness of the stiffer cell departs from the mean-field line tr F by "
        f"{100 * kn4['stiffness_excess_spring']:+.1f} % (ε with the spring), against "
        f"{100 * b['stiffness_excess_spring'][0]:+.1f} ± {100 * b['stiffness_excess_spring'][1]:.1f} % "
        "for B: it lies on the same line, as the paper states, although its packing is looser "
        f"(tr F {kn4['trF_bulk']:.2f} against {b['trF_bulk'][0]:.2f} in the bulk; the same "
        "forces make overlaps four times smaller), and the flow is the same (v₀ "
        f"{kn4['fit_v0']:.3f} against {seed_stats(base, 'fit_v0')[0]:.3f} ± "
        f"{seed_stats(base, 'fit_v0')[1]:.3f}: the hard-disk limit).",
        "",
        "**Stiffness without bottom and tangential friction.** The excess is "
        f"{100 * free['stiffness_excess_spring']:+.1f} %: on the line too, but in a cell that is "
        f"hardly a packing: {free['contacts_per_disk_bulk']:.2f} contacts per disk and tr F "
        f"{free['trF_bulk']:.2f} in the bulk, no disk touching the inner ring in the averaging "
        f"window, v₀ = {free['fit_v0']:.3f} (no shear band). Frictionless disks at B's v̄ = "
        "0.815 stay below their jamming density (≈ 0.84 for frictionless bidisperse disks, "
        "O'Hern et al. 2003), so the sheared cell flows as a dense gas; the collapse holds, "
        "but on the "
        "few contacts of rattling disks, not on a stressed network as in the paper's "
        "frictional cells.",
        "",
        "**The deviation from the mean field without shear (Ω = 0).** With ε from the spring "
        f"it is {100 * still['stiffness_excess_spring']:+.2f} % against "
        f"{100 * b['stiffness_excess_spring'][0]:+.2f} ± {100 * b['stiffness_excess_spring'][1]:.2f} % "
        "with shear: smaller, but the sheared value is itself within two standard errors of "
        "zero, so these runs cannot tell whether shear creates it. With ε from η (the "
        f"default of the in-situ averages) the sheared excess is {100 * b['stiffness_excess'][0]:+.1f} "
        f"± {100 * b['stiffness_excess'][1]:.1f} % and the unsheared one "
        f"{100 * still['stiffness_excess']:+.1f} %: there the deviation is made by the sliding "
        "that only shear causes, and it vanishes without it, as the paper says. The unsheared "
        "cell is also the only jammed one: after the compression it keeps "
        f"{still['contacts_per_disk_bulk']:.2f} contacts per disk (tr F {still['trF_bulk']:.2f}, "
        f"pressure {still['pressure_bulk']:.0f} N/m² in the bulk) against "
        f"{b['contacts_per_disk_bulk'][0]:.2f} ({b['trF_bulk'][0]:.2f}, "
        f"{b['pressure_bulk'][0]:.2f} N/m²) when sheared. Without the turning inner ring the "
        "compression leaves B a jammed, stressed network; with it (it turns from t = 0) the "
        "steady state is the nearly stress-free one of the sheared runs: the shear, not the "
        "preparation, unjams B.",
        "",
        "**M_zr in and outside the shear band (Fig. 1.8).** Under shear, |M_zr| averages "
        f"{b['M_zr_band'][0]:.1e} N/m at 0.25 ≤ r̃ ≤ 3 against an RMS of "
        f"{b['M_zr_outer_rms'][0]:.1e} N/m at 6 ≤ r̃ ≤ 15 (B, 3 seeds; {ratio:.0f} times "
        f"smaller; k_n × 4: {kn4['M_zr_band']:.1e} and {kn4['M_zr_outer_rms']:.1e}): large in "
        "the band, small outside, as the paper states. Outside it is not quite zero-mean "
        f"noise: {100 * b['M_zr_outer_within_2err'][0]:.0f} % of the outer rings lie within two "
        "block errors of zero, where noise alone would put 91 % there (errors from 8 blocks: "
        "Student's t with 7 degrees of freedom). Without shear the "
        "frozen packing keeps static couple stresses everywhere "
        f"({still['M_zr_band']:.1e} and {still['M_zr_outer_rms']:.1e} N/m at "
        f"about {round(still['pressure_bulk'] / b['pressure_bulk'][0], -2):,.0f} times the "
        "pressure) that do "
        "not fluctuate, so no ring is within two (vanishing) block errors of zero.",
    ]

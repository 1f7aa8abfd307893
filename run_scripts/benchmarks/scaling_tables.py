"""The tables of ``docs/scaling.md`` and ``docs/scaling_variants.md`` rendered from the
measurements committed in ``results/scaling/`` (one CSV file per table; its ``#`` header says what
was measured, by which script and command, and in which units). ``tests/test_manual.py`` checks
that the pages are current.

    python run_scripts/benchmarks/scaling_tables.py          # rewrites the pages' tables
    python run_scripts/benchmarks/scaling_tables.py --check  # exit 1 if a page is stale

In the page each table stands between ``<!-- table: NAME -->`` and ``<!-- end -->``; the text
around the markers is the page's own. A cell is the first of its templates whose fields are all
given in the row (empty if none is): ``{field}`` as written in the file, ``{field:,}`` an integer
with thousands separators. Ratios derived from a row (``_derived``) are computed here.
"""

from __future__ import annotations

import argparse
import csv
import re
import string
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "scaling.md"
VARIANTS_PAGE = ROOT / "docs" / "scaling_variants.md"
PAGES = {PAGE: ["throughput", "vs_lammps", "stages", "memory_hierarchy", "memory", "rank_counts",
                "machine_costs", "across_nodes"], VARIANTS_PAGE: ["variants"]}
DATA = ROOT / "results" / "scaling"

def _lo_hi(prefix: str, suffix: str = "") -> str:
    """The range of the fields PREFIX_minSUFFIX and PREFIX_maxSUFFIX."""
    return "{%s_min%s}–{%s_max%s}" % (prefix, suffix, prefix, suffix)


def _median_range(prefix: str, suffix: str = "") -> str:
    """The median PREFIXSUFFIX, then the range."""
    return "{%s%s}; " % (prefix, suffix) + _lo_hi(prefix, suffix)


# Per table: (markdown header, templates) for each column.
TABLES: dict[str, list[tuple[str, tuple[str, ...]]]] = {
    "throughput": [
        ("run", ("{run}",)),
        ("cell, t", ("{cell}, {t_s} s",)),
        ("free disks", ("{free_disks:,}",)),
        ("state", ("{state}",)),
        ("touching pairs per disk", ("{touching_pairs_per_disk}",)),
        ("1 rank, M/s (median; range)", (_median_range("one_rank", "_Mps"),)),
        ("per particle vs B", ("{per_particle_vs_B}",)),
        ("2 ranks, M/s (median; range)", (_median_range("two_ranks", "_Mps"),)),
        ("speed-up (median per round; range)", (_median_range("speedup"),)),
        ("ghosts / rank", ("{ghosts_per_rank}",)),
        ("builds / 1000 steps", ("{builds_per_1000_steps}",)),
        ("largest RSS per rank, MB, 1 / 2 ranks", ("{rss_one_rank_MB} / {rss_two_ranks_MB}",)),
    ],
    "vs_lammps": [
        ("one core; LAMMPS (same law and dt, skin 0.5 mm against 0.74, no bottom friction): "
         "its settled packing, sheared", ("{state}",)),
        ("pardem, M/s (median; range)", (_median_range("pardem", "_Mps"),)),
        ("LAMMPS, M/s (median; range)", (_median_range("lammps", "_Mps"),)),
        ("pardem / LAMMPS (per round)", ("{ratio} ({ratio_min}–{ratio_max})",)),
        ("bare loop, M/s (median; range)", (_median_range("bare", "_Mps"),)),
        ("pardem / bare loop (per round)", ("{vs_bare} ({vs_bare_min}–{vs_bare_max})",)),
        ("bare loop / LAMMPS", ("{bare_vs_lammps}",)),
    ],
    "stages": [
        ("µs per step", ("{run}",)),
        ("kicks + drift", ("{kick_drift_us}",)),
        ("refresh (wait, pack, unpack)",
         ("{refresh_us} ({refresh_wait_us}, {refresh_pack_us}, {refresh_unpack_us})",
          "{refresh_us} ({refresh_note})")),
        ("pair + ring forces", ("{forces_us}",)),
        ("closing kick", ("{closing_kick_us}",)),
        ("step", ("{step_us}",)),
        ("builds per step", ("{build_per_step_us}",)),
    ],
    "memory_hierarchy": [
        ("state", ("{state}",)),
        ("fraction with a force", ("{fraction_with_force} (windows {window_fraction_with_force})",
                                   "{fraction_with_force}")),
        ("whole list", ("{whole_list_ns}",)),
        ("7,000 pairs (B's list)", ("{window_7000_ns}",)),
        ("70,000", ("{window_70000_ns}",)),
        ("200,000", ("{window_200000_ns}",)),
        ("400,000", ("{window_400000_ns}",)),
        ("whole / 7,000", ("{whole_over_window}",)),
    ],
    "memory": [
        ("start", ("{start}",)),
        ("ranks", ("{ranks_covered}",)),
        ("steps", ("{steps}",)),
        ("set-up, s", (_lo_hi("set_up", "_s"),)),
        ("set-up's peak, MB (B per owned disk)",
         (_lo_hi("set_up_peak", "_MB") + " (" + _lo_hi("set_up_peak", "_B") + ")",
          "(" + _lo_hi("set_up_peak", "_B") + ")")),
        ("the run's peak, MB (B per owned disk)",
         (_lo_hi("run_peak", "_MB") + " (**" + _lo_hi("run_peak", "_B") + "**)",)),
    ],
    "rank_counts": [
        ("cell, t", ("{cell}, {t_s} s",)),
        ("P", ("{ranks}",)),
        ("cut (`--cut`)", ("{cut} ({requested})",)),
        ("owned / rank (max / mean)", ("{owned_mean:,} ({owned_imbalance})",)),
        ("ghosts / rank, mean; max", ("{ghosts_mean:,}; {ghosts_max:,}",)),
        ("ghosts / owned", ("{ghosts_per_owned}",)),
        ("neighbours, mean; max", ("{neighbours_mean}; {neighbours_max}",)),
        ("kB sent / step, mean; max", ("{kB_sent_mean}; {kB_sent_max}",)),
        ("pairs / rank (max / mean)", ("{pairs_mean:,} ({pairs_imbalance})",)),
        ("builds / 1000 steps; exchanges", ("{builds_per_1000}; {exchanges}",)),
        ("recount, largest deviation", ("{ghosts_same_positions_dev}",)),
        ("measured / placement law, mean; max",
         ("{measured_over_predicted_mean}; {measured_over_predicted_max}",)),
    ],
    "machine_costs": [
        ("quantity", ("{quantity}",)),
        ("median (range)", ("{median} ({low}–{high})",)),
        ("unit", ("{unit}",)),
        ("measured by", ("{source}",)),
    ],
    "across_nodes": [
        ("P", ("{ranks:,}",)),
        ("10⁶: owned / rank", ("{owned_1e6:,}",)),
        ("sectors: ghosts; efficiency (α range)",
         ("{sectors_1e6_ghosts:,}; **{sectors_1e6_efficiency}** ({sectors_1e6_efficiency_range})",
          "refused")),
        ("rings × sectors: cut, ghosts; efficiency",
         ("{rings_cut}, {rings_1e6_ghosts:,}; **{rings_1e6_efficiency}** "
          "({rings_1e6_efficiency_range})",)),
        ("10⁷: owned / rank", ("{owned_1e7:,}",)),
        ("sectors", ("{sectors_1e7_ghosts:,}; **{sectors_1e7_efficiency}** "
                     "({sectors_1e7_efficiency_range})", "refused")),
        ("rings × sectors", ("{rings_1e7_ghosts:,}; **{rings_1e7_efficiency}** "
                             "({rings_1e7_efficiency_range})",)),
    ],
    "variants": [
        ("variant", ("{variant}",)),
        ("measured effect", ("{measured_effect}",)),
        ("why not kept", ("{why_not_kept}",)),
    ],
}


def _derived(name: str, row: dict[str, str]) -> None:
    """Fields computed from a row's measurements."""
    if name == "memory_hierarchy":
        whole, window = row["whole_list_ns"], row["window_7000_ns"]
        row["whole_over_window"] = f"{float(whole) / float(window):.2f}" if whole and window else ""


def read(name: str) -> tuple[dict[str, str], list[dict[str, str]]]:
    """The ``# key: value`` header lines and the rows of results/scaling/NAME.csv."""
    lines = (DATA / f"{name}.csv").read_text(encoding="utf-8").splitlines()
    meta = {}
    for line in lines:
        if not line.startswith("#"):
            break
        key, sep, value = line[1:].strip().partition(":")
        if sep and " " not in key.strip():
            meta[key.strip()] = value.strip()
    rows = list(csv.DictReader(line for line in lines if not line.startswith("#")))
    for row in rows:
        _derived(name, row)
    return meta, rows


def _cell(templates: tuple[str, ...], row: dict[str, str]) -> str:
    for template in templates:
        fields = [f for _, f, _, _ in string.Formatter().parse(template) if f is not None]
        if all(row[f].strip() for f in fields):
            values = {f: int(row[f]) if re.fullmatch(r"-?\d+", row[f]) else row[f]
                      for f in fields}
            return template.format(**values).replace("|", "\\|")
    return ""


def render_table(name: str) -> str:
    meta, rows = read(name)
    columns = TABLES[name]
    out = ["| " + " | ".join(title for title, _ in columns) + " |",
           "|" + "---|" * len(columns)]
    out += ["| " + " | ".join(_cell(t, row) for _, t in columns) + " |" for row in rows]
    script = meta["script"].split(" (")[0]
    source = f"`{script}`" if script.startswith("run_scripts/") else script
    out += ["", f"*Data: `results/scaling/{name}.csv`, from {source}; the file gives the command "
            "and the units.*"]
    return "\n".join(out)


MARK = re.compile(r"(<!-- table: (\w+) -->\n)(.*?)(<!-- end -->)", re.S)


def render(text: str | None = None, page: Path = PAGE) -> str:
    """The page with every marked table rendered from its data file."""
    text = page.read_text(encoding="utf-8") if text is None else text
    names = [m.group(2) for m in MARK.finditer(text)]
    if sorted(names) != sorted(PAGES[page]):
        raise SystemExit(f"{page}: tables marked {sorted(names)}, expected {sorted(PAGES[page])}")
    return MARK.sub(lambda m: m.group(1) + render_table(m.group(2)) + " " + m.group(4), text)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if a page is stale")
    args = ap.parse_args()
    stale = []
    for page in PAGES:
        current = page.read_text(encoding="utf-8")
        new = render(current, page)
        if new == current:
            continue
        if args.check:
            stale.append(str(page.relative_to(ROOT)))
        else:
            page.write_text(new, encoding="utf-8")
            print(f"wrote {page.relative_to(ROOT)}")
    if stale:
        print(f"{', '.join(stale)} stale: run python run_scripts/benchmarks/scaling_tables.py")
        sys.exit(1)
    if args.check:
        print("the scaling pages are current")


if __name__ == "__main__":
    main()

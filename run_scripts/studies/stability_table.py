"""Where the stability limit is: the settled kinetic energy of a dense cell against dt/limit,
for each set of effects (docs/accuracy.md, "Stability limit").

    python run_scripts/studies/stability_table.py [--ratios 0.25,0.5,0.8,1,1.25,1.6] [--sets A,E]
                [--json docs/accuracy/stability.json]

Prints a markdown table: per set of effects, the admitted limit (pardem.core.stability.
stability_limit) and the median kinetic energy of the free disks 0.2-0.3 s after the
compression (pardem.testing.settled_kinetic_energy) at each multiple of the limit, over that
at the default t_c/50. A stable step lets a damped packing come to rest, so the ratio stays
within the scatter of settled states reached along other paths (1-20x: a frictionless packing
keeps rearranging now and then); a growing mode keeps it moving at the springs' Coulomb
limits or blows it up ("inf": the watchdog stopped the run). With the rolling spring the
disks get random spins (1 rad/s) when the compression ends: without friction nothing else
would turn them, and a rolling mode needs a seed to grow. Each set compiles its own kernels
(a minute or two each) and runs 7 small simulations (340 disks, 0.4 s): 30-40 minutes for
all 7 sets on a busy 2-core machine.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from pardem.testing import dense_cell, stability_drift
from pardem.core.scales import smallest_contact_time
from pardem.core.stability import stability_limit

ROLLING = {"k_r": 1e4, "mu_r": 1e3}  # stiff enough to set the limit, its cap far away
SPIN = 1.0  # rad/s: random spins when the compression ends, with rolling (a mode needs a seed)
SETS = {  # name: (rotation, friction, rolling, damping, [contact] changes)
    "A": (True, True, False, True, {}),
    "B": (True, True, True, True, ROLLING),
    "C": (True, False, True, True, ROLLING),
    "D": (True, False, False, True, {}),
    "E": (False, True, False, True, {}),
    "F": (False, False, False, True, {}),
    "G": (True, True, False, False, {}),
}
# Without any dissipation (no damping, no friction) t_c/5 binds (resolution), and this cell is
# no test of it: the compression heats the gas until collisions pass MAX_OVERLAP at any dt
# (the run stops); the elastic gas of docs/accuracy.md table 1 measures that set.


def scene_of(name: str):
    rotation, friction, rolling, damping, contact = SETS[name]
    return dense_cell({"rotation": rotation, "tangential_friction": friction,
                       "rolling_resistance": rolling, "normal_damping": damping}, contact)


def markdown(data: dict) -> list[str]:
    """The table of ``--json``'s data, as markdown lines."""
    on = {True: "on", False: "off"}
    lines = ["| set | rotation | friction | rolling | damping | limit (s) | t_c/limit | set by | "
             "KE at t_c/50 (J) | " + " | ".join(f"{r:g}×" for r in data["ratios"]) + " |",
             "|" + "---|" * (9 + len(data["ratios"]))]
    for row in data["rows"]:
        cells = ["inf" if d is None else f"{d:.2g}" for d in row["drift"]]
        lines.append(f"| {row['set']} | {on[row['rotation']]} | {on[row['friction']]} | "
                     f"{on[row['rolling']]} | {on[row['damping']]} | {row['limit']:.3g} | "
                     f"{row['t_c/limit']:.3g} | {row['mode']} | {row['ref']:.2g} | "
                     + " | ".join(cells) + " |")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ratios", default="0.25,0.5,0.8,1,1.25,1.6")
    ap.add_argument("--sets", default=",".join(SETS))
    ap.add_argument("--json", type=Path, help="also write the rows here (docs/accuracy/"
                    "stability.json: run_scripts/studies/accuracy_study.py puts them in its "
                    "section)")
    args = ap.parse_args(argv)
    data = {"ratios": [float(r) for r in args.ratios.split(",")], "rows": []}
    for name in args.sets.split(","):
        scene = scene_of(name)
        rotation, friction, rolling, damping, _ = SETS[name]
        limit, mode = stability_limit(scene)
        _, ref, drift = stability_drift(scene, data["ratios"], SPIN if rolling else 0.0)
        data["rows"].append({
            "set": name, "rotation": rotation, "friction": friction, "rolling": rolling,
            "damping": damping, "limit": limit, "t_c/limit": smallest_contact_time(scene) / limit,
            "mode": mode.split(",")[0], "ref": ref,
            "drift": [None if math.isinf(d) else d for d in drift]})
        print("\n".join(markdown(data)[-1:] if len(data["rows"]) > 1 else markdown(data)),
              flush=True)
        if args.json:
            args.json.write_text(json.dumps(data, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

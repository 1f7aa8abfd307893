"""The paper's cell B scaled up at fixed particle size and volume fraction: radii x k, disk
counts x k^2, wall disks x k (the same spacing along the rings, so the same roughness).

    python run_scripts/scaled_scene.py K OUT.toml [--end 30]

Writes couette_B.toml with those changes, its comments kept, a shorter run (``--end``, default
30 s; how long a scaled cell takes to reach steady shear is not measured yet), snapshots and
checkpoints every 10 s and averages over the last 10 s. Everything else is B's: material, time step, Omega (so the inner
wall moves k times faster), the 2 s compression from R_o' = 0.33 k m. The free disks' volume
fraction is B's; the wall disks' half-areas, 0.0047 of B's global 0.81, shrink to 0.0047 / k.
The shipped couette_B_30k, _300k and _1M are K = 3.2, 10 and 18.5 (30,096, 293,900 and
1,005,872 free disks).
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

B = Path(__file__).resolve().parent / "couette_B.toml"


def scaled(k: float, end: float = 30.0) -> str:
    text = B.read_text()

    def scale(key: str, factor: float, integer: bool = False) -> None:
        nonlocal text
        pattern = rf"^({key}\s*=\s*)([0-9.e+-]+)"
        assert re.search(pattern, text, flags=re.M), key

        def repl(m):
            v = float(m.group(2)) * factor
            new = str(int(round(v))) if integer else f"{v:.6g}"
            return m.group(1) + new.ljust(len(m.group(2)))

        text = re.sub(pattern, repl, text, flags=re.M)

    for key in ("inner_radius", "outer_radius", "outer_start_radius"):
        scale(key, k)
    for key in ("inner_wall_count", "outer_wall_count"):
        scale(key, k, integer=True)
    scale("count", k * k, integer=True)
    text = re.sub(r'^name = "couette-B"', f'name = "couette-B-x{k:g}"', text, flags=re.M)
    for key, value in (("end", end), ("snapshot_interval", 10.0), ("checkpoint_interval", 10.0),
                       ("start", max(end - 10.0, 2.5))):
        text = re.sub(rf"^({key}\s*=\s*)([0-9.e+-]+)", rf"\g<1>{value}", text, flags=re.M)
    header = (f"# pardem scene: the paper's B scaled by k = {k:g} (run_scripts/scaled_scene.py):\n"
              f"# radii x {k:g}, disk counts x {k * k:g}, wall disks x {k:g}; B's material.\n")
    return header + text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("k", type=float)
    ap.add_argument("out", type=Path)
    ap.add_argument("--end", type=float, default=30.0, help="s")
    args = ap.parse_args()
    if not args.k >= 1.0:
        raise SystemExit(f"scaled_scene.py: k = {args.k}: must be >= 1")
    args.out.write_text(scaled(args.k, args.end))
    print(f"{args.out}: B x {args.k:g}")


if __name__ == "__main__":
    main()

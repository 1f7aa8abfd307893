"""The paper's cell B scaled up at fixed particle size and volume fraction: radii x k, disk
counts x k^2, wall disks x k (the same spacing along the rings, so the same roughness).

    python run_scripts/tools/scaled_scene.py K OUT.toml [--end 30]

Writes couette_B.toml with those changes, its comments kept, a shorter run (``--end``, default
30 s), snapshots and checkpoints every 10 s and averages over the last 10 s. Material, time
step and Omega are B's (so the inner wall moves k times faster). The free disks' volume
fraction is B's; the wall disks' half-areas, 0.0047 of B's global 0.81, shrink to 0.0047 / k.

The start is not B's dilute one (R_o' = 0.33 m, area fraction 0.44) scaled: the outer ring
starts at the smallest radius at which the placement's lattice (spaced by the largest diameter)
still holds every disk, 1.001 times that for rounding (area fraction ~0.66 at the start, the
travel ~1/3 of a scaled B's). The ring moves in with B's compression profile at k times B's
speed (B's compression strain rate), but never faster than ``MAX_RING_SPEED``: 0.69 s at 30k
(not capped), 1.95 s at 300k, 3.56 s at 1M. A denser start than the lattice gives needs
overlapping disks to be relaxed, which the compression does.

The shipped couette_B_30k, _300k and _1M are K = 3.2, 10 and 18.5 (30,096, 293,900 and
1,005,872 free disks).

    python run_scripts/tools/scaled_scene.py K OUT.toml --ring-only

writes B itself with Omega x K instead: its inner wall as fast as the K-scaled cell's, over
B's protocol with its times divided by K (the same turns of the ring). It tells what a scaled
cell's step costs because it is larger from what it costs because its wall is faster (more
neighbour builds, contacts sliding and closing). The shipped couette_B_ring_x10 is K = 10.
"""

from __future__ import annotations

import argparse
import math
import re
import tomllib
from pathlib import Path

B = Path(__file__).resolve().parents[1] / "scenes" / "couette_B.toml"
MAX_RING_SPEED = 0.2
"""m/s: the compressing ring's largest speed in a scaled cell. A disk hit at speed v overlaps
it by up to v sqrt(m/k_n): 0.24 mm at 0.2 m/s, 2.6 % of B's large diameter (B's own ring: 0.061
m/s). Measured at 300k: 3.3 % largest overlap half a second after a compression at 0.195 m/s,
11.9 % at 0.61 m/s (k times B's speed)."""


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
    d = tomllib.loads(text)
    g = d["geometry"]
    diameters = [s["diameter"] for s in d["species"]]
    wall = g["wall_particle_diameter"]
    r_tight = tightest_start(g["inner_radius"] + wall / 2, sum(s["count"] for s in d["species"]),
                             max(diameters), wall)
    b = tomllib.loads(B.read_text())["geometry"]
    # the ring's peak speed on the cosine profile: pi/2 x travel / time
    peak = min(k * 0.5 * math.pi * (b["outer_start_radius"] - b["outer_radius"])
               / b["compression_time"], MAX_RING_SPEED)
    t_comp = 0.5 * math.pi * (r_tight - g["outer_radius"]) / peak
    for key, value, note in (
            ("outer_start_radius", r_tight, "m, the tightest lattice start (see scaled_scene.py)"),
            ("compression_time", round(t_comp, 3),
             f"s, ring speed up to {peak:.3g} m/s (see scaled_scene.py)")):
        line = f"{key} = {value:g}"
        text = re.sub(rf"^{key}\s*=.*$", f"{line:<33}# {note}", text, count=1, flags=re.M)
    text = re.sub(r'^name = "couette-B"', f'name = "couette-B-x{k:g}"', text, flags=re.M)
    for key, value in (("end", end), ("snapshot_interval", 10.0), ("checkpoint_interval", 10.0),
                       ("start", max(end - 10.0, 2.5))):
        text = re.sub(rf"^({key}\s*=\s*)([0-9.e+-]+)", rf"\g<1>{value}", text, flags=re.M)
    header = (f"# pardem scene: the paper's B scaled by k = {k:g} "
              "(run_scripts/tools/scaled_scene.py):\n"
              f"# radii x {k:g}, disk counts x {k * k:g}, wall disks x {k:g}; B's material.\n")
    return header + text


def fast_ring(k: float) -> str:
    """B with its inner ring k times as fast, and the times of its protocol after the
    compression (run end, averaging window, snapshots) divided by k: the same turns."""
    text = B.read_text()
    d = tomllib.loads(text)
    text = set_value(text, "geometry", "omega_inner", d["geometry"]["omega_inner"] * k)
    for table, key in (("time", "end"), ("averaging", "start"), ("averaging", "end"),
                       ("output", "snapshot_interval")):
        text = set_value(text, table, key, round(d[table][key] / k, 6))
    text = re.sub(r'^name = "couette-B"', f'name = "couette-B-ring-x{k:g}"', text, flags=re.M)
    return (f"# pardem scene: the paper's B with its inner ring {k:g} times as fast\n"
            "# (run_scripts/tools/scaled_scene.py --ring-only): the wall speed of B scaled by "
            f"k = {k:g};\n# protocol times / {k:g}.\n"
            + text)


def set_value(text: str, table: str, key: str, value: float) -> str:
    """``text`` with [table] key's number replaced by value, its comment kept in place."""
    lines, current, done = text.splitlines(keepends=True), None, False
    for n, line in enumerate(lines):
        if head := re.match(r"^\[+([a-z_]+)\]+", line):
            current = head.group(1)
        elif current == table and (m := re.match(rf"^({key}\s*=\s*)([0-9.e+-]+)", line)):
            lines[n] = m.group(1) + f"{value:g}".ljust(len(m.group(2))) + line[m.end():]
            done = True
    assert done, (table, key)
    return "".join(lines)


def tightest_start(r_inner_clear: float, n: int, d_max: float, wall: float) -> float:
    """The smallest outer ring radius (m; x 1.001, rounded up to 0.1 mm) at which the
    triangular lattice of pardem.input.placement (spacing 1.001 d_max, centres 1.01 d_max/2 clear of
    the rings' wall disks) has n sites: sites counted row by row, bisected on the radius."""
    s = 2.0 * (d_max / 2) * 1.001
    h = s * math.sqrt(3) / 2
    r_lo = r_inner_clear + d_max / 2 * 1.01

    def sites(r_hi: float) -> int:
        count = 0
        for j in range(-int(r_hi / h) - 1, int(r_hi / h) + 2):
            y2 = (j * h) ** 2
            if y2 > r_hi**2:
                continue
            shift = 0.5 * (j % 2)
            a_hi = math.sqrt(r_hi**2 - y2)
            a_lo = math.sqrt(r_lo**2 - y2) if y2 < r_lo**2 else -1.0
            # integers i with a_lo <= |(i + shift) s| <= a_hi
            right = math.floor(a_hi / s - shift) - math.ceil(max(a_lo, 0.0) / s - shift) + 1
            left = math.floor(a_hi / s + shift) - math.ceil(max(a_lo, 0.0) / s + shift) + 1
            both = right + left - (1 if a_lo < 0 and shift == 0 else 0)
            count += max(both, 0)
        return count

    def clear(r_out: float) -> float:  # the lattice's outer bound for an outer ring at r_out
        return r_out - wall / 2 - d_max / 2 * 1.01

    lo, hi = r_lo, r_lo + 2.0 * math.sqrt(n) * s
    while hi - lo > 1e-7 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if sites(clear(mid)) >= n else (mid, hi)
    return math.ceil(hi * 1.001 * 1e4) / 1e4


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("k", type=float)
    ap.add_argument("out", type=Path)
    ap.add_argument("--end", type=float, default=None, help="s (default 30)")
    ap.add_argument("--ring-only", action="store_true",
                    help="B with Omega x k (the k-scaled cell's wall speed), not B scaled")
    args = ap.parse_args()
    if not args.k >= 1.0:
        raise SystemExit(f"scaled_scene.py: k = {args.k}: must be >= 1")
    if args.ring_only and args.end is not None:
        raise SystemExit("scaled_scene.py: --ring-only takes B's protocol times / k; "
                         "--end applies only to a scaled cell")
    if args.ring_only:
        args.out.write_text(fast_ring(args.k))
        print(f"{args.out}: B with Omega x {args.k:g}")
    else:
        args.out.write_text(scaled(args.k, 30.0 if args.end is None else args.end))
        print(f"{args.out}: B x {args.k:g}")


if __name__ == "__main__":
    main()

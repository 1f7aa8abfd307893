"""The run machinery and the measures of the wall studies (roughness_study.py,
calibration_study.py): one scene run to its end with ``pardem run``, resumable from its
checkpoint, and one small JSON table per run in docs/roughness/runs/ with every measure of it.

    python run_scripts/studies/study_runs.py --remeasure [--runs runs/roughness]

recomputes the measures of every table whose run folder is still in RUNS (keeping each
table's command and wall time).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from averaging.offline import average_run  # noqa: E402
from averaging.order import psi6_profile  # noqa: E402
from averaging.report import global_volume_fraction, load_run, metrics  # noqa: E402
from pardem.output.snapshots import read_snapshots  # noqa: E402
from pardem.input.scene_file import load_scene, write_scene  # noqa: E402
from pardem.core.state import INNER_WALL  # noqa: E402
from pardem.boundaries.walls import wall_layout  # noqa: E402

DOCS = ROOT / "docs"
TABLES = DOCS / "roughness" / "runs"
SEEDS = (1, 2, 3)


def scene_for(sim: str, layout: str, seed: int, walls: dict, **changes):
    """Simulation sim (A, B, C) of the shipped scenes with the wall layout ``walls`` (its
    [geometry] keys; ``layout`` names it) and a seed; ``changes``: {table: {key: value}}."""
    base = load_scene(ROOT / "run_scripts" / "scenes" / f"couette_{sim}.toml")
    g = dataclasses.replace(base.geometry, **walls)
    scene = dataclasses.replace(base, geometry=g,
                                info=dataclasses.replace(base.info, seed=seed, name=(
                                    f"roughness-{layout}-{sim}-s{seed}")))
    for table, keys in changes.items():
        scene = dataclasses.replace(scene, **{table: dataclasses.replace(
            getattr(scene, table), **keys)})
    return scene

def wall_fraction(scene) -> float:
    """v-bar_wall: half of every wall disk's area over the cell's."""
    g = scene.geometry
    area = sum(0.5 * w.count * math.pi * w.diameter**2 / 4
               for w in (wall_layout(g, "inner"), wall_layout(g, "outer")))
    return area / (math.pi * (g.outer_radius**2 - g.inner_radius**2))

def run_one(name: str, scene, runs: Path, ranks: int) -> dict | None:
    """Run one scene (skipped if its JSON exists); returns its result row."""
    table = TABLES / f"{name}.json"
    if table.exists():
        return json.loads(table.read_text())
    out = runs / name
    out.mkdir(parents=True, exist_ok=True)
    path = out.parent / f"{name}.toml"
    write_scene(scene, path)
    bindir = Path(sys.executable).parent
    cmd = [str(bindir / "pardem"), "run", str(path), "--out", str(out), "--quiet"]
    # an interrupted run continues from its checkpoint, which carries the ring samples taken
    # so far; one written before pardem kept them (no rings_layout) only if it lies before
    # the averaging window. Else the run starts again, replacing the folder's files.
    restarted, has_samples = checkpoint_time(out / "checkpoint.h5")
    if restarted is not None and (has_samples or restarted < scene.averaging.start):
        cmd += ["--restart", str(out / "checkpoint.h5")]
    else:
        restarted = None
        cmd += ["--overwrite"]
    if ranks > 1:
        cmd = [str(bindir / "mpiexec"), "-n", str(ranks)] + cmd
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    print(f"[{name}] start {time.strftime('%H:%M:%S')}", flush=True)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        print(f"[{name}] FAILED ({done.returncode}) after {wall:.0f} s:\n{done.stderr[-2000:]}",
              flush=True)
        return None
    row = measure(out)
    row.update({"name": name, "wall_s": round(wall, 1), "ranks": ranks,
                "restarted_from_s": restarted,
                "command": " ".join(["pardem", "run", f"{name}.toml", "--out", name]
                                    if ranks == 1 else ["mpiexec", "-n", str(ranks), "pardem",
                                                        "run", f"{name}.toml", "--out", name])})
    TABLES.mkdir(parents=True, exist_ok=True)
    write_table(table, row)
    print(f"[{name}] done in {wall / 60:.1f} min: v0 {row['fit_v0']:.3f} s {row['fit_s']:.3f}",
          flush=True)
    return row

def checkpoint_time(path: Path) -> tuple[float | None, bool]:
    """Simulated time (s) of a run folder's checkpoint (None if there is none), and whether it
    carries the ring samples taken before it."""
    import h5py

    try:
        with h5py.File(path, "r") as h5:
            return float(h5.attrs["time"]), "rings_layout" in h5.attrs
    except (OSError, KeyError):
        return None, False

def measure(run_dir: Path) -> dict:
    """Every measure of the study for one finished run folder (rings.h5 + snapshots)."""
    run = load_run(run_dir)
    scene = load_scene(run_dir / "scene.toml")
    f = run["rings"]
    m = metrics(run)
    r = f["r_tilde"]
    out = {k: m[k] for k in ("nu_bulk", "dilation_deficit", "dilation_width",
                             "stiffness_excess", "inner_torque", "mu_c_outer")}
    # the study's tables: fit_* the log fit (as in its first runs), lin_* the primary fit
    out["fit_v0"], out["fit_s"] = m["fit_v0_log"], m["fit_s_log"]
    sheared = scene.geometry.omega_inner != 0
    sel = (r >= 0.25) & (r <= 8.1) & (f["v_phi_norm"] > 0)
    fit = out["fit_v0"] * np.exp(-r[sel] / out["fit_s"])
    out["fit_log_residual"] = (float(np.median(np.abs(np.log(f["v_phi_norm"][sel] / fit))))
                               if sheared else math.nan)
    out["lin_v0"], out["lin_s"] = (m["fit_v0"], m["fit_s"]) if sheared else (math.nan,) * 2
    band = (r >= 1) & (r <= 3)
    out["bulk_friction"] = float(np.mean(f["sigma_rphi"][band]) / np.mean(f["sigma_rr"][band]))
    bulk = (r >= 10) & (r <= 15)
    out["pressure_bulk"] = float(np.mean(0.5 * f["tr_sigma"][bulk]))  # N/m^2
    out["trF_bulk"] = float(np.mean(f["tr_F"][bulk]))
    out["contacts_per_disk_bulk"] = float(np.mean(f["C_number"][bulk]))
    out["v_phi_bulk"] = float(np.mean(np.abs(f["v_phi_norm"][bulk])))
    inner = (r >= 0.5) & (r <= 4)
    spin = f["excess_spin"][inner] / (scene.geometry.omega_inner if sheared else math.nan)
    smooth = np.convolve(spin, np.ones(8) / 8, mode="same")  # one d~ = 8 rings
    out["excess_spin_oscillation"] = float(np.std((spin - smooth)[4:-4]))
    # couple stress: large in the shear band, about zero outside (paper §1.6, Fig. 1.8)
    m_err = f.get("M_zr_err", np.full(r.size, np.nan))
    out["M_zr_band"] = float(np.mean(np.abs(f["M_zr"][(r >= 0.25) & (r <= 3)])))
    outer = (r >= 6) & (r <= 15)
    out["M_zr_outer_rms"] = float(np.sqrt(np.mean(f["M_zr"][outer] ** 2)))
    out["M_zr_outer_within_2err"] = float(np.mean(np.abs(f["M_zr"][outer]) < 2 * m_err[outer]))
    out.update(wall_contacts(run_dir, scene))
    # a frictionless cell can leave the inner ring untouched through the whole window
    load = scene.geometry.inner_radius * out["inner_normal_force"]
    out["wall_friction"] = out["inner_torque"] / load if load > 0 else math.nan
    for which in ("eta", "spring"):
        out.update(displacement_measures(run_dir, scene, which))
    out.update(regime_measures(run_dir, scene))
    out["v_bar_wall"] = wall_fraction(scene)
    out["v_bar"] = global_volume_fraction(scene)
    out["profile"] = {"r_tilde": r.tolist(), "v_phi_norm": f["v_phi_norm"].tolist(),
                      "nu": f["nu"].tolist(), "M_zr": f["M_zr"].tolist(),
                      "M_zr_err": f.get("M_zr_err", np.full(r.size, np.nan)).tolist(),
                      "kappa_zr": f["kappa_zr"].tolist(), "tr_F": f["tr_F"].tolist(),
                      "stiffness": f["stiffness"].tolist(),
                      "excess_spin": f["excess_spin"].tolist()}
    return out

def displacement_measures(run_dir: Path, scene, which: str) -> dict:
    """What the choice of the tangential contact displacement changes, from offline averages of
    the same snapshots (averaging window, 1 s apart) with Delta = delta n - eta or - xi: the
    stiffness's excess over the mean-field line tr F (paper: "some per cent"), the shear
    resistance pi G/k'_n over tr F in the shear band (Fig. 1.6: near the identity there), and
    mu_c/k'_n in the outer part."""
    f = average_run(run_dir, displacement=which).fields()
    k2 = scene.contact.k_n / scene.contact.height
    r = f["r_tilde"]
    zone = (r >= 1) & (r <= 15) & (f["tr_F"] > 0)
    band = (r >= 1) & (r <= 4) & (f["tr_F"] > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return {f"stiffness_excess_{which}": float(np.nanmean(
                    f["stiffness"][zone] / f["tr_F"][zone] - 1)),
                f"shear_resistance_over_trF_{which}": float(np.nanmedian(
                    f["shear_resistance"][band] / f["tr_F"][band])),
                f"mu_c_outer_{which}": float(np.nanmedian(f["mu_c"][(r >= 4) & (r <= 15)]) / k2),
                f"dev_eps_band_{which}": float(np.nanmean(f["dev_eps"][band]))}

def regime_measures(run_dir: Path, scene) -> dict:
    """The flow regime in the band (1 <= r~ <= 4) and the bulk (10 <= r~ <= 15), from offline
    averages of the snapshots in the averaging window (in-situ files of older runs lack the
    kinetic sums): inertial number (median over the rings), contacts per disk, pressure and
    its kinetic part, and psi_6 of the small disks (averaging/order.py)."""
    avg = average_run(run_dir)
    f = avg.fields()
    cfg, g = scene.averaging, scene.geometry
    r = f["r_tilde"]
    snaps = [s for s in read_snapshots(run_dir) if cfg.start - 1e-9 <= s["time"] <= cfg.end + 1e-9]
    out = {}
    for zone, (lo, hi) in (("band", (1, 4)), ("bulk", (10, 15))):
        sel = (r >= lo) & (r <= hi)
        with np.errstate(invalid="ignore"):
            out[f"I_{zone}"] = float(np.nanmedian(f["inertial_number"][sel]))
            out[f"contacts_{zone}"] = float(np.nanmean(f["C_number"][sel]))
            out[f"p_{zone}"] = float(np.nanmean(f["pressure"][sel]))
            out[f"p_kin_{zone}"] = float(np.nanmean(f["pressure_kin"][sel]))
        psi = psi6_profile(snaps, g.inner_radius, avg.d_ref, np.array([lo, hi], float))
        out[f"psi6_{zone}"] = float(psi[0])
    return out

def wall_contacts(run_dir: Path, scene) -> dict:
    """Contacts of free disks with the inner ring (its wall disks and its flat surface) in the
    snapshots of the averaging window: the fraction at the Coulomb cap, the angle of their
    normals from the wall normal e_r, the summed normal force, and v_phi/(Omega r) of the disks
    that touch it."""
    cfg, g, mu = scene.averaging, scene.geometry, scene.contact.mu
    capped, angles, normal_sum, ratios, n_snap, n_flat = [], [], [], [], 0, 0
    for snap in read_snapshots(run_dir):
        if not cfg.start - 1e-9 <= snap["time"] <= cfg.end + 1e-9:
            continue
        n_snap += 1
        c, kind = snap["contacts"], snap["kind"]
        on = kind[c["ids"][:, 1]] == INNER_WALL
        p = c["ids"][on, 0]
        normal, fn, ft = c["normal"][on], c["normal_force"][on], c["tangential_force"][on]
        ring = snap.get("ring_contacts")
        if ring is not None and len(ring["id"]):
            sel = ring["ring"] == 1
            n_flat += int(sel.sum())
            p = np.concatenate([p, ring["id"][sel]])
            normal = np.concatenate([normal, ring["normal"][sel]])
            fn = np.concatenate([fn, ring["normal_force"][sel]])
            ft = np.concatenate([ft, ring["tangential_force"][sel]])
        x = snap["position"][p]
        er = x / np.hypot(x[:, 0], x[:, 1])[:, None]
        ephi = np.column_stack([-er[:, 1], er[:, 0]])
        angles.append(np.degrees(np.arctan2(np.sum(normal * ephi, 1), np.sum(normal * er, 1))))
        with np.errstate(divide="ignore", invalid="ignore"):
            mob = np.hypot(ft[:, 0], ft[:, 1]) / (mu * np.abs(fn))
        capped.append(mob >= 0.999)
        normal_sum.append(fn.sum())
        touching = np.unique(p)
        xt, vt = snap["position"][touching], snap["velocity"][touching]
        rt = np.hypot(xt[:, 0], xt[:, 1])
        vphi = (xt[:, 0] * vt[:, 1] - xt[:, 1] * vt[:, 0]) / rt
        ratios.append(vphi / (g.omega_inner * rt) if g.omega_inner else vphi * 0)
    if not n_snap:
        raise RuntimeError(f"{run_dir}: no snapshot in the averaging window")
    ang = np.abs(np.concatenate(angles))
    c = snap["contacts"]  # the window's last snapshot: sizes of the three displacements
    sizes = {f"mean_{k}": float(np.mean(v)) for k, v in (
        ("overlap", c["overlap"]), ("spring", np.hypot(*c["spring"].T)),
        ("eta", np.hypot(*c["displacement"].T) if "displacement" in c else np.nan))}
    capped = np.concatenate(capped)
    return {**sizes,
            "inner_capped_fraction": float(capped.mean()) if capped.size else math.nan,
            "inner_normal_angle_mean": float(ang.mean()) if ang.size else math.nan,
            "inner_normal_angle_median": float(np.median(ang)) if ang.size else math.nan,
            "inner_normal_force": float(np.mean(normal_sum)),
            "inner_contacts_per_snapshot": float(ang.size / n_snap),
            "inner_flat_share": float(n_flat / max(ang.size, 1)),
            "first_layer_speed": float(np.mean(np.concatenate(ratios))),
            "snapshots": n_snap}

def seed_stats(rows: list[dict], key: str):
    vals = np.array([r[key] for r in rows], float)
    err = vals.std(ddof=1) / math.sqrt(len(vals)) if len(vals) > 1 else math.nan
    return float(vals.mean()), float(err)

def rows_of(prefix: str) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted(TABLES.glob(f"{prefix}-s*.json"))]

def fmt(rows: list[dict], key: str, digits: int = 3) -> str:
    rows = [r for r in rows if key in r]  # tables of older runs lack the newer measures
    if not rows:
        return "–"
    mean, err = seed_stats(rows, key)
    if len(rows) == 1 or not math.isfinite(err):
        return f"{mean:.{digits}f}"
    return f"{mean:.{digits}f} ± {err:.{digits}f}"

MEASURES = [("fit_v0", "v₀ (log fit)", 3), ("fit_s", "s (log fit)", 3),
            ("lin_v0", "v₀ (linear fit)", 3), ("lin_s", "s (linear fit)", 3),
            ("first_layer_speed", "v_φ/(Ωr), disks touching the inner ring", 3),
            ("inner_capped_fraction", "inner-wall contacts at the Coulomb cap", 3),
            ("inner_normal_angle_mean", "mean |angle| of their normals from e_r (deg)", 1),
            ("inner_flat_share", "share of them on the flat inner surface", 3),
            ("wall_friction", "wall friction T_in/(R_i Σf_n)", 3),
            ("bulk_friction", "σ_rφ/σ_rr at 1 ≤ r̃ ≤ 3", 3),
            ("pressure_bulk", "pressure ½tr σ at 10 ≤ r̃ ≤ 15 (N/m²)", 4),
            ("trF_bulk", "tr F at 10 ≤ r̃ ≤ 15", 3),
            ("contacts_per_disk_bulk", "contacts per disk at 10 ≤ r̃ ≤ 15", 3),
            ("dilation_deficit", "dilation ν(10–15) − ν(1–4)", 4),
            ("excess_spin_oscillation", "excess-spin oscillation (std / Ω, 0.5 ≤ r̃ ≤ 4)", 4),
            ("stiffness_excess", "(2πĒ/k'_n)/tr F − 1 at 1 ≤ r̃ ≤ 15 (ε with η)", 3),
            ("mu_c_outer", "μ_c/k'_n, median at 4 ≤ r̃ ≤ 15", 4),
            ("stiffness_excess_eta", "offline, Δ with η: (2πĒ/k'_n)/tr F − 1", 3),
            ("stiffness_excess_spring", "offline, Δ with the spring: (2πĒ/k'_n)/tr F − 1", 3),
            ("shear_resistance_over_trF_eta", "offline, η: (πG/k'_n)/tr F at 1 ≤ r̃ ≤ 4", 3),
            ("shear_resistance_over_trF_spring", "offline, spring: (πG/k'_n)/tr F at 1–4", 3),
            ("mu_c_outer_eta", "offline, η: μ_c/k'_n at 4 ≤ r̃ ≤ 15", 4),
            ("mu_c_outer_spring", "offline, spring: μ_c/k'_n at 4 ≤ r̃ ≤ 15", 4),
            ("M_zr_band", "mean |M_zr| at 0.25 ≤ r̃ ≤ 3 (N/m)", 7),
            ("M_zr_outer_rms", "RMS M_zr at 6 ≤ r̃ ≤ 15 (N/m)", 7),
            ("M_zr_outer_within_2err", "share of rings at 6 ≤ r̃ ≤ 15 with |M_zr| < 2 errors", 3),
            ("wall_s", "wall time per run (s; 2 runs at a time on 2 shared cores)", 0)]

def measure_rows(measures, groups) -> list[str]:
    """One table row per measure: its label, then fmt() of every group of runs."""
    return [f"| {label.replace('|', chr(92) + '|')} | "
            + " | ".join(fmt(rows, key, digits) for rows in groups) + " |"
            for key, label, digits in measures]

def claim_rows(name: str) -> list[dict]:
    table = TABLES / f"{name}.json"
    return [json.loads(table.read_text())] if table.exists() else []


def write_table(table: Path, row: dict) -> None:
    tmp = table.with_suffix(".tmp")
    tmp.write_text(json.dumps(row, indent=1, sort_keys=True))
    os.replace(tmp, table)


def remeasure(runs: Path) -> None:
    """Every table whose run folder is in ``runs``, measured again (command and wall kept)."""
    for table in sorted(TABLES.glob("*.json")):
        row = json.loads(table.read_text())
        if (runs / row["name"] / "rings.h5").exists():
            new = measure(runs / row["name"])
            new.update({k: row[k] for k in ("name", "wall_s", "ranks", "command",
                                            "restarted_from_s", "paused_s") if k in row})
            write_table(table, new)
            print(f"remeasured {row['name']}", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=Path, default=ROOT / "runs" / "roughness")
    ap.add_argument("--remeasure", action="store_true", required=True)
    remeasure(ap.parse_args(argv).runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())

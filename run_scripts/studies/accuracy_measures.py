"""The measurements of the accuracy study (run_scripts/studies/accuracy_study.py): each function
runs one experiment and returns plain numbers; the study turns them into tables and plots.

Every error is against an independent reference: the analytic damped spring (collisions), the
initial energy (elastic gas), the finest time step (Couette profiles), the exact disk-ring
overlap at the finest ring width (averaging), and the measured autocorrelation (sampling).
"""

from __future__ import annotations

import math
import statistics
import time
from pathlib import Path

import numpy as np

from averaging.io import read_rings
from averaging.sample import snapshot_sample
from averaging.timeavg import RingAverager
from pardem.contact.damped_spring import contact_time, restitution
from pardem.output.snapshots import read_snapshots
from pardem.input.schema import scene_from_dict
from pardem.input.scene_file import load_scene
from pardem.simulation import Simulation
from pardem.testing import D_S, M_S, elastic_gas_energy_error, measure, two_disks

SCENES = Path(__file__).resolve().parents[1] / "scenes"
K_N, GAMMA_N = 352.1, 0.19
SMALL_CELL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
              "compression_time": 0.1, "omega_inner": 3.0}


def collision_errors(n_per_contact: float, integrator: str, phases: int) -> dict:
    """Worst relative errors of t_c and e_n over ``phases`` entry phases (two small disks)."""
    tc, e = contact_time(K_N, GAMMA_N, M_S / 2), restitution(K_N, GAMMA_N, M_S / 2)
    got = np.array([measure(*two_disks(D_S, M_S, tc / n_per_contact, p / phases, integrator))
                    for p in range(phases)])
    return {"t_c": float(np.abs(got[:, 0] / tc - 1).max()),
            "e_n": float(np.abs(got[:, 1] / e - 1).max())}


def energy_error(n_per_contact: float, integrator: str, sim_time: float, seeds) -> dict:
    """Elastic gas (no dissipation): mean and worst relative energy deviation over sim_time."""
    steps = max(int(round(sim_time / (contact_time(K_N, 0.0, M_S / 2) / n_per_contact))), 50)
    rows = [elastic_gas_energy_error(n_per_contact, steps, seed, integrator) for seed in seeds]
    return {"mean": float(np.mean([r[0] for r in rows])), "worst": max(r[1] for r in rows)}


def couette_profiles(n_per_contact: float, integrator: str, end: float) -> dict:
    """A small sheared cell (300 disks, 3 rad/s): nu and v_phi/(Omega R_i) in rings of d~/2,
    averaged over the second half of the run, with their block errors and the wall time."""
    scene = scene_from_dict({
        "scene": {"name": "profiles", "kind": "couette", "seed": 3}, "geometry": SMALL_CELL,
        "species": [{"name": "small", "diameter": D_S, "mass": M_S, "count": 260},
                    {"name": "large", "diameter": 8.99e-3, "mass": 0.490e-3, "count": 40}],
        "time": {"dt_per_contact": n_per_contact, "integrator": integrator, "end": end},
        "averaging": {"start": end / 2, "end": end, "sample_interval": 0.01,
                      "ring_width": 4e-3, "reference_diameter": 8e-3}})
    sim = Simulation(scene)
    t0 = time.perf_counter()
    sim.run(progress=False)
    wall = time.perf_counter() - t0
    f = sim.rings.fields()
    return {"nu": f["nu"], "nu_err": f["nu_err"], "v": f["v_phi_norm"],
            "v_err": f["v_phi_norm_err"], "wall": wall, "steps": sim.step}


def compressed_paper_cell(path: Path) -> Path:
    """Scene B compressed (t = 2.5 s) and checkpointed once; the cost rows continue from it."""
    if not path.exists():
        sim = Simulation(load_scene(SCENES / "couette_B.toml"))
        sim.run(end=2.5, progress=False)
        sim.write_checkpoint(path)
    return path


def step_cost(ckpt: Path, n_per_contact: float | None = None, skin_d: float | None = None,
              integrator: str = "verlet", steps: int = 4000, repeats: int = 3) -> dict:
    """Median wall time per step on the compressed paper cell (one core), continued at dt =
    t_c/n_per_contact and/or with a Verlet skin of skin_d small diameters; rebuilds per 1000
    steps, listed pairs. (The checkpoint is the default run's; dt and skin are changed on the
    restored state, which is what a user changing them mid-run would get.)"""
    scene = load_scene(SCENES / "couette_B.toml")
    times, rebuilds, pairs = [], [], []
    for _ in range(repeats):
        sim = Simulation(scene, restart=ckpt)
        if integrator != "verlet" or n_per_contact is not None or skin_d is not None:
            _retune(sim, n_per_contact, skin_d, integrator)
        sim.advance_steps(20)
        b0 = sim.n_rebuilds
        t0 = time.perf_counter()
        sim.advance_steps(steps)
        times.append((time.perf_counter() - t0) / steps)
        rebuilds.append(1000 * (sim.n_rebuilds - b0) / steps)
        pairs.append(sim.stats()["pairs"])
    step = statistics.median(times)
    return {"step_s": step, "dt": sim.dt, "wall_per_sim_s": step / sim.dt,
            "rebuilds_per_1000": statistics.median(rebuilds), "pairs": int(np.median(pairs)),
            "mps": sim.n_free / step / 1e6}


def _retune(sim, n_per_contact, skin_d, integrator):
    """Change a running simulation's dt, skin or integrator in place (a study's shortcut that
    keeps the packing; not an interface)."""
    from pardem.core.step import make_stepper

    if n_per_contact is not None:  # keep the simulated time: time = step * dt
        t = sim.time
        sim.dt = contact_time(K_N, GAMMA_N, M_S / 2) / n_per_contact
        sim.prm = sim.prm._replace(dt=sim.dt, law=sim.prm.law._replace(dt=sim.dt))
        sim.clock.step[0] = int(round(t / sim.dt))
    if skin_d is not None:
        sim.prm = sim.prm._replace(skin=skin_d * D_S)
    if integrator != "verlet":
        sim.contact = sim.contact._replace(window=False)
        sim.options = sim.options._replace(predict=False, contact=sim.contact)
        sim.stepper = make_stepper(sim.options)
    sim.refresh()


def averaging_grid(run_dir: Path, widths: list[float], weightings: list[str],
                   max_snapshots: int) -> dict:
    """For every (weighting, ring width): nu profile, its block errors and the cost per sample,
    from the run's snapshots in its averaging window (the same samples for all)."""
    scene = load_scene(run_dir / "scene.toml")
    cfg, g = scene.averaging, scene.geometry
    t_lo = cfg.start if cfg else 0.0
    snaps = [s for s in read_snapshots(run_dir) if s["time"] >= t_lo - 1e-9]
    snaps = snaps[-max_snapshots:]
    samples = [(snapshot_sample(s), s["time"]) for s in snaps]
    out = {}
    for weighting in weightings:
        for dr in widths:
            avg = RingAverager(g.inner_radius, g.outer_radius, dr, weighting,
                               scene.contact.height, cfg.reference_diameter or 8e-3,
                               scene.contact.k_n, g.omega_inner)
            t0 = time.perf_counter()
            for smp, t in samples:
                avg.add(smp, t)
            cost = (time.perf_counter() - t0) / len(samples)
            f = avg.fields()
            out[(weighting, dr)] = {"r": f["r"], "r_tilde": f["r_tilde"], "nu": f["nu"],
                                    "nu_err": f["nu_err"], "v": f["v_phi_norm"],
                                    "cost": cost}
    return {"grid": out, "samples": len(samples), "window": (snaps[0]["time"], snaps[-1]["time"])}


def sampling(run_dir: Path, intervals: list[float]) -> dict:
    """From a run's in-situ samples: per-sample v_phi/(Omega R_i) of the shear zone
    (1 <= r~ <= 3) and tr sigma of the bulk (5 <= r~ <= 15); their integrated autocorrelation
    times, and the error of the time average when sampling every ``interval`` seconds."""
    rings = read_rings(run_dir)
    cols = {c: k for k, c in enumerate(rings["columns"])}
    s, rt, r = rings["sums"], rings["r_tilde"], rings["r"]
    scene = load_scene(run_dir / "scene.toml")
    g, h = scene.geometry, scene.contact.height
    dt = float(np.median(np.diff(rings["times"])))
    zone, bulk = (rt >= 1) & (rt <= 3), (rt >= 5) & (rt <= 15)
    v = s[:, zone, cols["mom_phi"]].sum(axis=1) / s[:, zone, cols["vol"]].sum(axis=1)
    v = v / (g.omega_inner * g.inner_radius)
    vol = (2 * math.pi * h * r * (r[1] - r[0]))[bulk].sum()
    tr = (s[:, bulk, cols["stress_rr"]] + s[:, bulk, cols["stress_phiphi"]]).sum(axis=1) / vol
    out = {"dt": dt, "n": int(v.size), "T": float(v.size * dt),
           "in_situ_cost": logged_averaging_cost(run_dir, v.size)}
    for name, x in (("v_phi", v), ("tr_sigma", tr)):
        tau, rho = autocorrelation_time(x, dt)
        rows = []
        for interval in intervals:
            every = max(int(round(interval / dt)), 1)
            sub = x[::every]
            blocks = np.array([b.mean() for b in np.array_split(sub, 8)])
            rows.append({"interval": every * dt, "samples": int(sub.size),
                         "err": float(blocks.std(ddof=1) / math.sqrt(len(blocks))),
                         "err_model": float(x.std(ddof=1) * math.sqrt(
                             max(2 * tau, every * dt) / (sub.size * every * dt)))})
        out[name] = {"mean": float(x.mean()), "std": float(x.std(ddof=1)), "tau": tau,
                     "rho": rho[:min(rho.size, int(20 / dt))], "rows": rows}
    return out


def logged_averaging_cost(run_dir: Path, samples: int):
    """(s per sample, share of the run) from the stage breakdown in the run's log.txt, or None
    for a run without a log."""
    log = run_dir / "log.txt"
    if not log.exists():
        return None
    stages = {}
    for line in log.read_text().splitlines():
        parts = line.split()
        if len(parts) >= 4 and parts[-1] == "%" and parts[-3] == "s":
            stages[" ".join(parts[:-4])] = float(parts[-4])
    if "averaging" not in stages:
        return None
    return stages["averaging"] / samples, stages["averaging"] / sum(stages.values())


def autocorrelation_time(x: np.ndarray, dt: float) -> tuple[float, np.ndarray]:
    """Integrated autocorrelation time tau = dt (1/2 + sum rho(k)) (s), summed up to the
    self-consistent window k <= 5 tau/dt (Sokal); and the autocorrelation function rho."""
    y = x - x.mean()
    n = y.size
    f = np.fft.rfft(y, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[:n] / np.arange(n, 0, -1)
    rho = acf / acf[0]
    tau = 0.5
    for k in range(1, n):
        tau += rho[k]
        if k >= 5 * tau:
            break
    return float(tau * dt), rho


def throughput_by_ranks(ranks: list[int], steps: int, repeats: int) -> dict[int, float]:
    import sys

    sys.path.insert(0, str(SCENES.parent / "benchmarks"))
    import bench

    return bench.throughput(steps, repeats, ranks)

"""Benchmark: what each effect of ``[effects]`` costs per step (a disabled effect costs nothing),
and what the optional contact slots (tangential damping, rolling resistance) cost when on.

    python run_scripts/benchmarks/bench_effects.py [--steps 4000] [--repeats 5]

Compresses the paper cell (couette_B, 2939 disks) once with every effect on (t = 0 .. 2.5 s,
not timed). Every variant then starts from that same packing at that time (same positions,
velocities, spins, wall disks included; springs start at zero), so all variants begin with the
same contacts. One core, in-process; the
variants take turns (round k runs each once) so the machine's slow drifts hit all alike.

Printed per variant, as medians over the rounds:
1. the cost of one force evaluation of that identical state, and of its contacts alone (the
   call minus the same call with the contact lists emptied): what compiling an effect out
   saves on the same work;
2. runs of ``--steps`` steps from that state: time per step, split into the compiled step loop
   and the neighbour builds, builds per 1000 steps, touching and listed pairs. A disabled
   effect changes the physics too (a frictionless packing flows more, so it needs more
   neighbour builds), which this table shows separately from the kernel's cost. dt differs between
variants only where the scene's dt = "auto" depends on the effect (normal damping).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import tomllib
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
SCENES = Path(__file__).resolve().parents[1] / "scenes"

ALL = ("normal_damping", "tangential_friction", "rotation", "bottom_friction")
# label -> ([effects] changes, [contact] changes); "all on": the paper's effects, the optional
# slots off
VARIANTS = {"all on": ({}, {}),
            **{f"{name} off": ({name: False}, {}) for name in ALL},
            "all off": ({name: False for name in ALL}, {}),
            "+ tangential_damping": ({"tangential_damping": True}, {"gamma_t": 0.05}),
            "+ rolling_resistance": ({"rolling_resistance": True}, {"k_r": 267.1, "mu_r": 0.1})}


def scene_dict(variant: tuple[dict, dict]) -> dict:
    effects, contact = variant
    d = tomllib.loads((SCENES / "couette_B.toml").read_text(encoding="utf-8"))
    for key in ("output", "averaging"):
        d.pop(key, None)
    d["effects"] = {**d["effects"], **effects}
    d["contact"] = {**d["contact"], **contact}
    return d


def packed_state():
    """``(t, arrays)``: the time (s) and every body's data, sorted by id
    (``Simulation.particle_arrays``), after compression with every effect on."""
    from pardem.input.schema import scene_from_dict
    from pardem.simulation import Simulation

    sim = Simulation(scene_from_dict(scene_dict(VARIANTS["all on"]), base_dir=SCENES))
    t0 = time.perf_counter()
    sim.run(end=2.5, progress=False)
    print(f"compression to t = 2.5 s: {time.perf_counter() - t0:.1f} s "
          f"wall, {sim.contacts()['ids'].shape[0]} touching pairs", flush=True)
    return sim.time, sim.particle_arrays()


def start(variant: tuple[dict, dict], state):
    """A run of a variant at the packed state's time, every disk (wall disks too) placed as in
    that state; springs start at zero. (It sets the clock and the arrays directly: a benchmark's
    shortcut, not an interface.)"""
    from pardem.input.schema import scene_from_dict
    from pardem.simulation import Simulation

    t, arrays = state
    sim = Simulation(scene_from_dict(scene_dict(variant), base_dir=SCENES))
    ps, n = sim.ps, int(sim.clock.n_local[0])
    sim.clock.step[0] = round(t / sim.dt)  # dt depends on the effects (damping)
    for name, key in (("x", "position"), ("v", "velocity"), ("theta", "theta"),
                      ("omega", "omega")):
        getattr(ps, name)[:n] = arrays[key][ps.gid[:n]]
    sim.refresh()
    sim.advance_steps(10)  # compiled code loaded, caches warm
    return sim


def kernel_times(state, calls: int, repeats: int) -> dict[str, dict[str, list[float]]]:
    """Seconds per force evaluation (``Stepper.compute_forces``) of the same state, per variant:
    "call" with every pair and ring contact (springs reset before each call, so every call does
    the same work), "empty" with the contact lists emptied (what remains: the Python call,
    zeroing the sums, copying the predicted velocities)."""
    def per_call(sim, xi0):
        t0 = time.perf_counter()
        for _ in range(calls):
            sim.pairs.hist[:] = xi0
            sim.stepper.compute_forces(sim.ps, sim.pairs, sim.clock, sim.prm, sim.decomp.halo, 0.01)
        return (time.perf_counter() - t0) / calls

    sims = {label: start(variant, state) for label, variant in VARIANTS.items()}
    out = {label: {"call": [], "empty": []} for label in VARIANTS}
    for _ in range(repeats):
        for label, sim in sims.items():
            pairs, xi0 = sim.pairs, sim.pairs.hist.copy()
            out[label]["call"].append(per_call(sim, xi0))
            counts = int(pairs.count[0]), int(pairs.wall_count[0])
            pairs.count[0] = pairs.wall_count[0] = 0
            out[label]["empty"].append(per_call(sim, xi0))
            pairs.count[0], pairs.wall_count[0] = counts
    return out


def run_times(state, steps: int, repeats: int) -> dict[str, dict[str, list[float]]]:
    """Per variant and round: wall time per step, the step loop's and the neighbour builds'
    shares, builds, touching and listed pairs (means of start and end)."""
    keys = ("step", "loop", "builds", "n_builds", "touching", "listed")
    out = {label: {k: [] for k in keys} for label in VARIANTS}
    for k in range(repeats):
        for label, variant in VARIANTS.items():
            sim = start(variant, state)
            sim.reset_timers()
            b0 = sim.n_rebuilds
            n0, m0 = sim.contacts()["ids"].shape[0], int(sim.pairs.count[0])
            t0 = time.perf_counter()
            sim.advance_steps(steps)
            r = out[label]
            r["step"].append((time.perf_counter() - t0) / steps)
            r["loop"].append(sim.timers["forces+integration"] / steps)
            r["builds"].append(sim.timers["neighbour rebuild"] / steps)
            r["n_builds"].append(1000 * (sim.n_rebuilds - b0) / steps)
            r["touching"].append((n0 + sim.contacts()["ids"].shape[0]) / 2)
            r["listed"].append((m0 + int(sim.pairs.count[0])) / 2)
        print(f"round {k + 1}: " + ", ".join(f"{lbl} {1e6 * r['step'][-1]:.1f}"
                                            for lbl, r in out.items()) + " us/step", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--calls", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    state = packed_state()
    med = statistics.median

    kern = kernel_times(state, a.calls, a.repeats)
    contact = {label: [c - e for c, e in zip(k["call"], k["empty"])] for label, k in kern.items()}
    base = med(contact["all on"])
    print(f"\n1. Force evaluation of one identical state (the compressed couette_B packing, "
          f"{state[1]['id'].size} bodies), median of {a.repeats} x {a.calls} calls, one core")
    print(f"  {'variant':24s} {'us/call':>8s} {'empty':>6s} {'contacts':>9s} {'vs all on':>10s}"
          "  contacts, repeats (us)")
    for label, t in contact.items():
        print(f"  {label:24s} {1e6 * med(kern[label]['call']):8.1f} "
              f"{1e6 * med(kern[label]['empty']):6.1f} {1e6 * med(t):9.1f} "
              f"{100 * (med(t) / base - 1):+9.1f}%  " + ", ".join(f"{1e6 * x:.1f}" for x in t))

    runs = run_times(state, a.steps, a.repeats)
    base = med(runs["all on"]["step"])
    print(f"\n2. Runs of {a.steps} steps from that state, median of {a.repeats} rounds, one core "
          "(the physics differs: each variant's packing evolves its own way)")
    print(f"  {'variant':24s} {'us/step':>8s} {'vs all on':>10s} {'loop us':>8s} "
          f"{'builds us':>9s} {'builds/1000 steps':>17s} {'touching':>9s} {'listed':>7s}")
    for label, r in runs.items():
        m = {k: med(v) for k, v in r.items()}
        print(f"  {label:24s} {1e6 * m['step']:8.1f} {100 * (m['step'] / base - 1):+9.1f}% "
              f"{1e6 * m['loop']:8.1f} {1e6 * m['builds']:9.1f} {m['n_builds']:17.1f} "
              f"{m['touching']:9.0f} {m['listed']:7.0f}")


if __name__ == "__main__":
    main()

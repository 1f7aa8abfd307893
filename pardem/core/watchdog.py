"""What a stopped run says: a particle that went bad, an overlap the contact law cannot
represent. Stage: front (Simulation._stop raises SimulationError with these on every rank)."""

from __future__ import annotations

from ..contact.overlap import MAX_OVERLAP


def bad_particle_message(sim, k: int) -> str:
    """Row k of ``sim``'s particles became non-finite or left the cell."""
    ps = sim.ps
    x, ref = ps.x[k], ps.x_ref[k]
    return (f"particle id {int(ps.gid[k])} became invalid at t = {sim.time:.6f} s (step "
            f"{sim.step}): position ({x[0]:.6g}, {x[1]:.6g}) m, velocity "
            f"({ps.v[k, 0]:.6g}, {ps.v[k, 1]:.6g}) m/s (non-finite, or outside the cell; "
            f"at the last neighbour-list build it was at ({ref[0]:.6g}, {ref[1]:.6g}) m); "
            "the last checkpoint is kept")


def too_deep_message(deep, dt: float) -> str:
    """Clock.deep = (t, i, j, ratio): the deepest overlap beyond MAX_OVERLAP (j < 0: the inner
    (-1) or outer ring's surface)."""
    t, i, j, ratio = deep
    partner = (f"particle id {int(j)}" if j >= 0 else
               f"the {'inner' if j == -1 else 'outer'} ring's surface")
    return (f"particle id {int(i)} and {partner} overlap by {100 * ratio:.3g} % of the "
            f"smaller free diameter at t = {t:.6f} s, beyond the {100 * MAX_OVERLAP:.0f} % the "
            "linear contact law represents (the disks would pass through each other): they "
            f"met too fast for dt = {dt:.4g} s and k_n; lower the speeds or dt, or "
            "raise [contact] k_n; the last checkpoint is kept")

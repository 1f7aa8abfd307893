"""The loads on the rings (averaging/boundary.py): each ring's torque on the particles, the
particles' force on it and their radial push, against analytic values (disks pressed into
the outer ring with a known overlap, a disk sliding along it), against Newton's third law and
the angular momentum balance of a sheared cell, in situ and from the gathered tables alike.

Every scene here runs pardem's default effects (the kernels the other Couette tests compile);
damping and bottom friction are switched off through their coefficients where a test needs
them gone.
"""

import math

import numpy as np
import pytest
from helpers import D_SMALL, K_N, K_T, MU, couette_scene

from averaging.boundary import LOADS, ring_loads, total_loads
from averaging.sample import sample_simulation
from pardem.simulation import Simulation

R_IN, R_OUT = 0.05, 0.09
A = D_SMALL / 2
DELTA = 1e-4  # m, the overlap each disk is pressed in with


def loads_now(sim) -> dict:
    """The loads in situ (the averaging's route) after checking that the gathered tables (the
    snapshot route) give the same bits."""
    in_situ = dict(zip(LOADS, total_loads(sample_simulation(sim).wall_rows)))
    gathered = ring_loads(sim.particle_arrays(), sim.contacts(), sim.ring_contacts())
    assert gathered == in_situ
    return in_situ


def still_cell(n: int, outer_walls: int, gamma_n: float = 0.0, mu_bottom: float = 0.0):
    """n small disks in a cell whose outer ring stands at its final radius from t = 0 (no
    compression), both rings smooth unless ``outer_walls`` disks are glued to the outer one."""
    g = {"inner_radius": R_IN, "outer_radius": R_OUT, "outer_start_radius": R_OUT,
         "compression_time": 0.1, "omega_inner": 0.0, "inner_wall_count": 0,
         "outer_wall_count": outer_walls}
    return Simulation(couette_scene(counts=(n, 0), geometry=g,
                                    contact={"gamma_n": gamma_n, "mu_bottom": mu_bottom}))


def place(sim, phi: np.ndarray, r: np.ndarray, velocity=None) -> None:
    x = np.column_stack([r * np.cos(phi), r * np.sin(phi)])
    sim.set_particles(np.arange(phi.size), position=x,
                      velocity=np.zeros_like(x) if velocity is None else velocity,
                      omega=np.zeros(phi.size))


@pytest.mark.parametrize("route", ["flat surface", "wall disks"])
def test_disks_pressed_into_the_outer_ring_push_it_with_k_n_delta(route):
    """Disks at rest pressed into the outer ring by DELTA, through its flat surface or through
    glued wall disks (radially behind each free disk, off the surface): each pushes with
    k_n DELTA along its radius. One disk: the ring feels k_n DELTA e_r(phi) and no torque;
    eight evenly spaced: the radial push 8 k_n DELTA, no net force, no torque. The inner ring
    carries nothing."""
    n = 8
    walls = n if route == "wall disks" else 0
    sim = still_cell(n, walls)
    a_wall = sim.scene.geometry.wall_particle_diameter / 2
    reach = A + a_wall if walls else A  # centre distance at first touch: wall disk or surface
    phi = 2 * math.pi * np.arange(n) / n  # the wall disks' angles (the first at 0)
    r_touch = R_OUT - reach + DELTA
    away = R_IN + 2 * A + 0.005  # the other disks: touching nothing
    radii = np.full(n, away)
    radii[0] = r_touch
    place(sim, phi + np.where(np.arange(n) == 0, 0.0, 0.2), radii)
    one = loads_now(sim)
    push = K_N * DELTA
    assert one["outer_radial_force"] == pytest.approx(push, rel=1e-9)
    assert one["outer_force_x"] == pytest.approx(push, rel=1e-9)  # disk 0 sits at phi = 0
    assert abs(one["outer_force_y"]) <= 1e-12 * push
    assert abs(one["outer_torque"]) <= 1e-12 * push * R_OUT
    place(sim, phi, np.full(n, r_touch))
    ring = loads_now(sim)
    assert ring["outer_radial_force"] == pytest.approx(n * push, rel=1e-9)
    for key in ("outer_force_x", "outer_force_y"):
        assert abs(ring[key]) <= 1e-12 * n * push
    assert abs(ring["outer_torque"]) <= 1e-12 * n * push * R_OUT
    assert all(ring[k] == 0.0 for k in LOADS if k.startswith("inner"))


def test_a_disk_sliding_along_the_outer_ring_feels_mu_k_n_delta_at_the_contact_radius():
    """A disk pressed into the smooth outer ring by DELTA and sent along it at 2 m/s
    counter-clockwise slides at once (the spring reaches mu f_n / k_t within two steps). The
    ring holds it back with mu k_n delta acting at the contact point, radius R_o + delta/2
    (halfway through the overlap): torque on the particle -mu k_n delta (R_o + delta/2),
    radial push k_n delta, with delta from the disk's position at that moment (no damping)."""
    sim = still_cell(1, 0)
    r = R_OUT - A + DELTA
    place(sim, np.array([0.4]), np.array([r]),
          velocity=2.0 * np.array([[-math.sin(0.4), math.cos(0.4)]]))
    assert MU * K_N * DELTA / K_T < 2 * 2.0 * sim.dt  # sliding after two steps
    sim.advance_steps(4)
    x = sim.particle_arrays()["position"][0]
    delta = A - (R_OUT - math.hypot(*x))
    loads = loads_now(sim)
    assert delta == pytest.approx(DELTA, rel=0.05)  # still pressed in about as placed
    assert loads["outer_radial_force"] == pytest.approx(K_N * delta, rel=1e-9)
    assert loads["outer_torque"] == pytest.approx(-MU * K_N * delta * (R_OUT + delta / 2),
                                                  rel=1e-9)


@pytest.fixture(scope="module")
def sheared():
    """A small dense cell with glued disks on both rings (the default layout), compressed in
    0.1 s and sheared at 10 rad/s, without bottom friction (mu_bottom = 0): a closed system
    but for the rings."""
    g = {"inner_radius": R_IN, "outer_radius": R_OUT, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 10.0}
    sim = Simulation(couette_scene(counts=(260, 40), geometry=g, contact={"mu_bottom": 0.0}))
    sim.run(end=0.15, progress=False)
    return sim


def angular_momentum(sim) -> float:
    """L (kg m^2/s) of the free disks about the axis: sum m x × v + (m d^2/8) omega."""
    p = sim.gathered("position", "velocity", "omega", "radius", "mass")
    free = p["kind"] == 0
    x, v, m = p["position"][free], p["velocity"][free], p["mass"][free]
    return (math.fsum(m * (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0]))
            + math.fsum(m * (2 * p["radius"][free]) ** 2 / 8 * p["omega"][free]))


def test_newtons_third_law_the_rings_take_what_the_disks_get(sheared):
    """Disk-disk forces cancel pairwise and act at a common contact point, so the force and
    torque on all free disks together (their own per-particle sums, the integrator's) are
    what both rings exert: sum f_i = -(F_in + F_out) on the rings, sum (x_i × f_i + tau_i) =
    T_in + T_out."""
    loads = loads_now(sheared)
    p = sheared.gathered("position", "force", "torque")
    free = p["kind"] == 0
    x, f, tau = p["position"][free], p["force"][free], p["torque"][free]
    scale = np.abs(f).sum()
    for c, axis in enumerate("xy"):
        on_rings = loads[f"inner_force_{axis}"] + loads[f"outer_force_{axis}"]
        assert abs(math.fsum(f[:, c]) + on_rings) <= 1e-9 * scale, axis
    torque = math.fsum(x[:, 0] * f[:, 1] - x[:, 1] * f[:, 0]) + math.fsum(tau)
    assert torque == pytest.approx(loads["inner_torque"] + loads["outer_torque"],
                                   rel=1e-9, abs=1e-9 * scale * R_OUT)
    assert loads["inner_torque"] > 0 > loads["outer_torque"]  # driven inside, held outside
    assert loads["outer_radial_force"] > 0 and loads["inner_radial_force"] > 0  # compressed


def test_torque_balance_of_the_rings_is_the_packings_angular_momentum_change(sheared):
    """Over 200 steps, T_in + T_out (sampled every step, trapezoid rule) equals dL/dt of the
    free disks from their velocities and spins at the two ends; both terms are of the size
    of the torques (the packing spins up after its compression)."""
    l0, steps = angular_momentum(sheared), 200
    total = [torque_sum(sheared)]
    for _ in range(steps):
        sheared.advance_steps(1)
        total.append(torque_sum(sheared))
    dl_dt = (angular_momentum(sheared) - l0) / (steps * sheared.dt)
    applied = (math.fsum(total) - 0.5 * (total[0] + total[-1])) / steps
    t_in = loads_now(sheared)["inner_torque"]
    print(f"\nT_in {t_in:.4e} N m, T_in + T_out {applied:.4e} N m, dL/dt {dl_dt:.4e} N m")
    assert abs(applied - dl_dt) < 1e-3 * abs(t_in)


def torque_sum(sim) -> float:
    """T_in + T_out (N m) now, in situ."""
    loads = total_loads(sample_simulation(sim).wall_rows)
    return float(loads[LOADS.index("inner_torque")] + loads[LOADS.index("outer_torque")])


def test_a_checkpoint_from_before_the_ring_loads_continues_with_its_inner_torques(tmp_path):
    """A checkpoint written before pardem kept the ring loads holds the inner torque of its
    samples only: a restart continues the averages with those torques and leaves the other
    loads of those samples NaN (not made up); the samples after it carry all loads, equal
    to an uninterrupted run's."""
    import h5py

    from averaging.io import read_rings
    from pardem.cli import main
    from pardem.input.scene_file import write_scene

    g = {"inner_radius": R_IN, "outer_radius": R_OUT, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 10.0}
    scene = couette_scene(counts=(260, 40), geometry=g, output={"checkpoint_interval": 0.1},
                          averaging={"start": 0.15, "end": 0.25, "sample_interval": 0.025})
    write_scene(scene, tmp_path / "s.toml")
    for folder, end in (("whole", "0.25"), ("cut", "0.2")):
        assert main(["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / folder),
                     "--end", end, "--quiet"]) == 0
    checkpoint = tmp_path / "cut" / "checkpoint.h5"
    with h5py.File(checkpoint, "r+") as h5:
        del h5["rings_loads"]
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "cut"), "--end",
                 "0.25", "--restart", str(checkpoint), "--quiet"]) == 0
    whole = read_rings(tmp_path / "whole")["ring_loads_samples"]
    cut = read_rings(tmp_path / "cut")["ring_loads_samples"]
    assert whole.shape == cut.shape == (5, len(LOADS)) and np.isfinite(whole).all()
    np.testing.assert_array_equal(cut[:, 0], whole[:, 0])  # inner torque: every sample
    assert np.isnan(cut[:3, 1:]).all()  # 0.15, 0.175, 0.2 s: from the old checkpoint
    np.testing.assert_array_equal(cut[3:], whole[3:])

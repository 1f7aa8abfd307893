"""The Couette cell: compression of the paper's scene B to a stable packing, and a shear band."""

import numpy as np
import pytest
from helpers import couette_scene

from pardem.neighbors import brute_force_pairs
from pardem.simulation import Simulation


def test_verlet_list_always_holds_every_touching_pair():
    sim = Simulation(couette_scene(counts=(400, 60), geometry={"outer_start_radius": 0.17,
                                                               "outer_radius": 0.15}))
    for _ in range(30):
        sim.advance_steps(97)
        n = sim.clock.n_local[0]
        listed = {(int(sim.ps.gid[i]), int(sim.ps.gid[j]))
                  for i, j in zip(sim.pairs.i[: sim.pairs.count[0]],
                                  sim.pairs.j[: sim.pairs.count[0]])}
        touching = brute_force_pairs(sim.ps.x[:n], sim.ps.radius[:n], sim.ps.gid[:n],
                                     sim.ps.kind[:n], 0.0)
        assert touching <= listed
    assert sim.n_rebuilds > 3


@pytest.fixture(scope="module")
def sheared_b():
    """Scene B (the paper's counts and cell), compressed in 2 s, relaxed and sheared to t = 5 s
    (largest overlap measured there, 3 s after the ring stopped), then
    v_phi averaged over 20 snapshots (t = 5 .. 7 s) in rings one reference diameter wide."""
    sim = Simulation(couette_scene(counts=(2545, 394)))
    sim.run(end=3.0, progress=False)
    transient = sim.max_overlap()
    sim.run(end=5.0, progress=False)
    print(f"\n largest overlap / d: 1 s after compression {transient:.4f} (transient)")
    overlap_after_compression = sim.max_overlap()
    total, count = np.zeros(30), np.zeros(30)
    for k in range(20):
        sim.run(end=5.0 + 0.1 * (k + 1), progress=False)
        x, v = sim.ps.x[: sim.n_free], sim.ps.v[: sim.n_free]
        r = np.hypot(x[:, 0], x[:, 1])
        ring = ((r - 0.1035) / 8e-3).astype(int)
        np.add.at(total, ring, (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0]) / r / (0.1 * 0.1035))
        np.add.at(count, ring, 1)
    return sim, overlap_after_compression, total / np.maximum(count, 1)


def test_compressed_packing_is_stable(sheared_b):
    sim, overlap, _ = sheared_b
    print(f"\n largest overlap / d: t = 5 s {overlap:.4f}, at t = 7 s "
          f"{sim.max_overlap():.4f}")
    assert overlap < 0.05
    assert sim.max_overlap() < 0.05
    r = np.hypot(*sim.ps.x[: sim.n_free].T)
    assert r.min() > 0.1035 and r.max() < 0.2525
    assert sim.kinetic_energy() < 1e-4  # J; the packing is not exploding


def test_inner_ring_drags_a_shear_band(sheared_b):
    _, _, v_phi = sheared_b
    print("\n v_phi/(Omega R_i) per ring of width d~:", np.round(v_phi[:12], 4))
    assert v_phi[0] > 0.3
    assert abs(v_phi[10]) < 0.1 * v_phi[0]
    assert np.all(np.diff(v_phi[:5]) < 0)  # decays away from the inner ring

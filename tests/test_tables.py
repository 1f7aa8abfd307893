"""Ring fields as xarray and pandas tables and the CSV files: what a physicist opens reads the
same numbers as rings.h5, with plain names, units, and time-resolved fields formed like the
time average."""

import numpy as np
import pytest
from helpers import couette_scene

from averaging.io import csv_units, read_rings
from averaging.tables import ring_dataset, ring_frame
from pardem.simulation import Simulation

pd = pytest.importorskip("pandas")
xr = pytest.importorskip("xarray")

CELL = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
        "compression_time": 0.1, "omega_inner": 3.0}
TIMES = [0.1, 0.15, 0.2, 0.25]  # the samples: every 0.05 s from 0.1 s to 0.25 s


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    scene = couette_scene(counts=(260, 40), geometry=CELL, output={"snapshot_interval": 0.1},
                          averaging={"start": 0.1, "end": 0.25, "sample_interval": 0.05},
                          time={"end": 0.25})
    sim = Simulation(scene, out_dir=out)
    sim.run(progress=False)
    return out, scene


def test_the_average_of_all_samples_recomputed_from_the_sums_is_the_time_average(run):
    """One group of every sample, formed on reading from the stored sums and normalisations,
    gives the fields the run averaged in memory, bit for bit."""
    out, _ = run
    stored = read_rings(out)
    whole = ring_dataset(out, every=len(TIMES))
    assert whole.sizes["time"] == 1
    for key in ("nu", "v_phi", "tr_sigma", "stiffness", "v_phi_norm", "fit_s", "inner_torque"):
        np.testing.assert_array_equal(whole[key].values[0], stored[key], key)


def test_single_sample_volume_fractions_average_to_the_time_average(run):
    """nu = vol / V_ring is linear in the sums with a fixed denominator, so the mean of the
    samples' nu is the time-averaged nu (a ratio like v_phi has no such identity)."""
    out, _ = run
    per_sample = ring_dataset(out, every=1)
    assert per_sample["time"].values.tolist() == TIMES
    np.testing.assert_allclose(per_sample["nu"].mean("time"), read_rings(out)["nu"],
                               rtol=1e-12, atol=1e-15)


def test_dataset_coordinates_units_and_descriptions(run):
    out, scene = run
    ds = ring_dataset(out)
    g, dr = scene.geometry, ds.attrs["ring_width"]
    np.testing.assert_allclose(ds["r"], g.inner_radius + (np.arange(ds.sizes["ring"]) + 0.5) * dr,
                               rtol=1e-14)
    assert ds["nu"].dims == ("ring",) and ds["fit_v0"].dims == ()
    assert ds["v_phi"].attrs["unit"] == "m/s" and ds["v_phi_err"].attrs["unit"] == "m/s"
    assert ds["r"].attrs["unit"] == "m" and ds["nu"].attrs["unit"] == "1"
    assert "standard error" in ds["nu_err"].attrs["description"]
    assert ring_dataset(out, every=2)["time"].attrs["unit"] == "s"
    with pytest.raises(ValueError, match="every = 0"):
        ring_dataset(out, every=0)


def test_tidy_frame_has_one_row_per_time_and_ring(run):
    out, _ = run
    frame = ring_frame(out, every=1)
    n_rings = ring_dataset(out).sizes["ring"]
    assert len(frame) == len(TIMES) * n_rings
    assert {"time", "ring", "r", "r_tilde", "nu", "v_phi"} <= set(frame.columns)
    assert frame.attrs["units"]["v_phi"] == "m/s"
    assert sorted(set(frame["time"])) == TIMES


def test_csv_files_open_in_pandas_with_plain_names_and_a_units_line(run):
    out, _ = run
    rings = read_rings(out)
    table = pd.read_csv(out / "rings.csv", comment="#")
    assert not any("[" in c or " " in c for c in table.columns)
    for key in ("r", "nu", "v_phi", "v_phi_err", "tr_sigma"):
        np.testing.assert_array_equal(table[key].to_numpy(), rings[key], key)
    units = csv_units(out / "rings.csv")
    assert units["r"] == "m" and units["v_phi"] == "m/s" and units["nu_err"] == "1"
    blocks = pd.read_csv(out / "rings_blocks.csv", comment="#")
    n_rings = rings["nu"].size
    # four samples in four blocks (at most 8): each block is one sample, at its time
    assert len(blocks) == len(TIMES) * n_rings
    np.testing.assert_array_equal(blocks["time"].to_numpy(), np.repeat(TIMES, n_rings))
    assert csv_units(out / "rings_blocks.csv")["time"] == "s"
    # the blocks' volume fractions average to the time average (linear in the sums)
    np.testing.assert_allclose(blocks.groupby("ring")["nu"].mean().to_numpy(), rings["nu"],
                               rtol=1e-12, atol=1e-15)

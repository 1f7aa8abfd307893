"""The worked example of the Python interface (examples/prepare_and_branch.py, shown in
docs/python.md) runs as written, on a tiny cell with short times."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from helpers import couette_scene

from pardem.input.scene_file import write_scene

pytest.importorskip("xarray")
ROOT = Path(__file__).resolve().parents[1]


def _example():
    spec = importlib.util.spec_from_file_location("prepare_and_branch",
                                                  ROOT / "examples" / "prepare_and_branch.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_prepare_and_branch_example_runs_and_friction_costs_torque(tmp_path):
    """test_branch.py's small dense cell (300 disks, rough rings), prepared to 0.15 s, then
    sheared at mu = 0.1 and 0.8 to 0.45 s. Coulomb friction carries the shear stress, so the
    inner ring needs more torque at the higher mu; the ring turns counter-clockwise and drags
    the disks next to it along (v_phi > 0 in the innermost ring)."""
    scene = couette_scene(counts=(260, 40), geometry={
        "inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
        "compression_time": 0.1, "omega_inner": 1.0},
        output={"checkpoint_interval": 0.05, "snapshot_interval": 0.05},
        averaging={"start": 0.0, "end": 1.0, "sample_interval": 0.005})
    write_scene(scene, tmp_path / "tiny.toml")
    fields, torques = _example().prepare_and_branch(tmp_path / "tiny.toml", tmp_path / "out",
                                                    prepare=0.15, end=0.45)
    assert (tmp_path / "out" / "v_phi.png").stat().st_size > 10_000
    for mu in (0.1, 0.8):
        ds = fields[mu]
        assert ds["v_phi"].dims == ("ring",) and ds["v_phi"].attrs["unit"] == "m/s"
        assert np.all(np.diff(ds["r"].values) > 0) and ds["v_phi"].values[0] > 0
        assert ds.attrs["n_samples"] == round((0.45 - 0.15) / 0.005) + 1  # both ends
    assert torques[0.8] > 1.5 * torques[0.1] > 0

"""Checkpoint + restart continues the trajectory bit for bit (frictional Couette scene with rings,
compression and wall disks, so contact history and the ring angle are exercised)."""

import dataclasses

import numpy as np
import pytest
from helpers import couette_scene

from pardem.input.scene import SceneError
from pardem.input.schema import scene_from_dict
from pardem.simulation import Simulation

FIELDS = ("gid", "x", "v", "theta", "omega", "f", "tau", "hist_wall", "pair_lo", "pair_hi",
          "pair_hist", "pair_force", "ring_force")


def small_cell(**geometry):
    # a narrow annulus with few particles keeps the test fast but dense enough for contacts
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 1.0, **geometry}
    return couette_scene(counts=(260, 40), geometry=g, output={"checkpoint_interval": 0.05,
                                                              "snapshot_interval": 0.05})


@pytest.mark.parametrize("chunk", [None, 7])
def test_restart_reproduces_uninterrupted_run_bitwise(tmp_path, monkeypatch, chunk):
    """Also with the checkpoint read 7 rows at a time (``restart.CHUNK_ROWS``), so that the
    shares and pair tables are put together from many chunks and partial ones."""
    if chunk is not None:
        monkeypatch.setattr("pardem.output.restart.CHUNK_ROWS", chunk)
    scene = small_cell()
    ref = Simulation(scene, out_dir=tmp_path / "ref")
    ref.run(end=0.15, progress=False)
    ckpt = tmp_path / "mid.h5"
    ref.write_checkpoint(ckpt)
    ref.run(end=0.3, progress=False)
    assert ref.contacts()["ids"].shape[0] > 50  # dense: many loaded contacts
    state = ref.checkpoint_state()[0]
    assert np.abs(state["pair_hist"]).max() > 0

    again = Simulation(scene, out_dir=tmp_path / "again", restart=ckpt)
    assert again.time == pytest.approx(0.15, abs=again.dt)
    again.run(end=0.3, progress=False)
    got = again.checkpoint_state()[0]
    for name in FIELDS:
        np.testing.assert_array_equal(got[name], state[name], name)
    a, b = again.contacts(), ref.contacts()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], key)


def test_contacts_right_after_a_restart_report_the_applied_forces(tmp_path):
    """The checkpoint carries the forces the last step applied: a run continued from it reports
    the same contacts, forces included, before taking a step."""
    sim = Simulation(small_cell(), out_dir=tmp_path)
    sim.run(end=0.15, progress=False)
    sim.write_checkpoint(tmp_path / "c.h5")
    again = Simulation(small_cell(), out_dir=tmp_path / "again", restart=tmp_path / "c.h5")
    a, b = again.contacts(), sim.contacts()
    assert b["ids"].shape[0] > 50 and np.abs(b["normal_force"]).min() > 0
    for key in b:
        np.testing.assert_array_equal(a[key], b[key], key)
    a, b = again.ring_contacts(), sim.ring_contacts()
    assert b["id"].size > 0
    for key in b:
        np.testing.assert_array_equal(a[key], b[key], key)


def test_restart_of_a_different_scene_is_refused(tmp_path):
    sim = Simulation(small_cell(), out_dir=tmp_path)
    sim.write_checkpoint(tmp_path / "c.h5")
    with pytest.raises(SceneError, match=r"different scene: \[geometry\] omega_inner: 1\.0 in "
                                         r"the checkpoint, 2\.0 here"):
        Simulation(small_cell(omega_inner=2.0), restart=tmp_path / "c.h5")


def test_truncated_checkpoint_is_refused(tmp_path):
    sim = Simulation(small_cell(), out_dir=tmp_path)
    sim.write_checkpoint(tmp_path / "c.h5")
    data = (tmp_path / "c.h5").read_bytes()
    (tmp_path / "bad.h5").write_bytes(data[: len(data) // 2])
    with pytest.raises(SceneError, match="bad.h5"):
        Simulation(small_cell(), restart=tmp_path / "bad.h5")


AVERAGING = {"start": 0.1, "end": 0.3, "sample_interval": 0.025, "ring_width": 2e-3}


def averaged_cell(**averaging):
    scene = small_cell()
    return dataclasses.replace(scene, averaging=scene_from_dict(
        {**scene.to_dict(), "averaging": {**AVERAGING, **averaging}}).averaging)


def test_a_restart_continues_the_ring_averages_exactly(tmp_path):
    """The checkpoint carries the ring samples taken so far: a run interrupted inside the
    averaging window and continued from its checkpoint writes the uninterrupted run's
    rings.h5, every sample and field bit for bit (same rank count)."""
    from averaging.io import read_rings

    ref = Simulation(averaged_cell(), out_dir=tmp_path / "ref")
    ref.run(end=0.3, progress=False)
    cut = Simulation(averaged_cell(), out_dir=tmp_path / "cut")
    cut.run(end=0.2, progress=False)  # 5 of the 9 samples, then the final checkpoint
    again = Simulation(averaged_cell(), out_dir=tmp_path / "cut",
                       restart=tmp_path / "cut" / "checkpoint.h5")
    assert len(again.rings.samples) == 5
    again.run(end=0.3, progress=False)
    a, b = read_rings(tmp_path / "cut"), read_rings(tmp_path / "ref")
    assert b["times"].size == 9 and np.abs(b["sums"]).max() > 0
    assert set(a) == set(b)
    for key in b:
        np.testing.assert_array_equal(a[key], b[key], key)


@pytest.mark.parametrize("change, message", [
    ({"ring_width": 3e-3}, r"ring_width = 0\.002.*has 0\.003"),
    ({"weighting": "exact"}, "weighting"),
    ({"displacement": "eta"}, "displacement"),
    ({"sample_interval": 0.05}, "start or sample_interval differ"),
    ({"start": 0.15}, "start or sample_interval differ"),
])
def test_a_restart_whose_averaging_cannot_continue_the_samples_is_refused(tmp_path, change,
                                                                           message):
    sim = Simulation(averaged_cell(), out_dir=tmp_path)
    sim.run(end=0.15, progress=False)
    with pytest.raises(SceneError, match=message):
        Simulation(averaged_cell(**change), restart=tmp_path / "checkpoint.h5")


def test_averaging_that_starts_before_a_checkpoint_without_samples_is_refused(tmp_path):
    """A checkpoint written without [averaging] (or by pardem before it kept the samples)
    cannot feed averages that should have begun before it; one from before the window can."""
    sim = Simulation(small_cell(), out_dir=tmp_path)
    sim.run(end=0.15, progress=False)
    with pytest.raises(SceneError, match=r"holds no ring samples.*start = 0\.1 s"):
        Simulation(averaged_cell(), restart=tmp_path / "checkpoint.h5")
    later = Simulation(averaged_cell(start=0.2), restart=tmp_path / "checkpoint.h5")
    assert later.rings.samples == []


def test_end_before_the_checkpoint_is_an_error(tmp_path):
    sim = Simulation(small_cell(), out_dir=tmp_path)
    sim.run(end=0.15, progress=False)
    again = Simulation(small_cell(), out_dir=tmp_path, restart=tmp_path / "checkpoint.h5")
    with pytest.raises(SceneError, match=r"--end 0\.1 s lies before the run's current time "
                                         r"0\.15"):
        again.run(end=0.1, progress=False)


def test_averaging_past_the_run_end_is_said(tmp_path, capsys):
    sim = Simulation(averaged_cell(), out_dir=tmp_path)
    sim.run(end=0.15, progress=False)
    note = ("[averaging] end = 0.3 s lies past this run's end 0.15 s: the averages cover "
            "0.1 s to 0.15 s")
    assert note in capsys.readouterr().err and note in (tmp_path / "log.txt").read_text()


def test_an_output_time_off_the_step_is_said(tmp_path, capsys):
    """Snapshots every 0.0123 s: 282.9 steps of 10 ms / 230; rounded, and said so."""
    scene = small_cell()
    scene = dataclasses.replace(scene, output=dataclasses.replace(scene.output,
                                                                  snapshot_interval=0.0123))
    sim = Simulation(scene, out_dir=tmp_path)
    sim.run(end=0.02, progress=False)
    note = ("[output] snapshot_interval = 0.0123 s not a whole number of steps of 4.34783e-05 "
            "s: rounded to the nearest step")
    assert note in capsys.readouterr().err and note in (tmp_path / "log.txt").read_text()


def test_a_restart_that_notes_a_missing_eta_runs_in_a_new_folder(tmp_path):
    """The restore's notes go to the new folder's log.txt once the folder is claimed: written
    before, they made the folder look like another run's, and the restart was refused."""
    sim = Simulation(small_cell())  # no output, no averaging: no eta kept
    sim.run(end=0.15, progress=False)
    sim.write_checkpoint(tmp_path / "c.h5")
    again = Simulation(averaged_cell(start=0.2), out_dir=tmp_path / "new",
                       restart=tmp_path / "c.h5")
    again.run(end=0.2, progress=False)
    lines = (tmp_path / "new" / "log.txt").read_text().splitlines()
    assert "the checkpoint has no eta" in lines[0]
    assert (tmp_path / "new" / "checkpoint.h5").exists()

"""`pardem plot` and the paper-comparison metrics (averaging/plots.py, averaging/report.py)."""

from pathlib import Path

import numpy as np
import pytest
from helpers import couette_scene

from averaging.report import block_mean, global_volume_fraction, load_run, metrics, ring_torques
from pardem.cli import main
from pardem.input.scene_file import load_scene, write_scene

ROOT = Path(__file__).parent.parent


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plot")
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 3.0}
    scene = couette_scene(counts=(260, 40), geometry=g, output={"snapshot_interval": 0.5},
                          averaging={"start": 0.1, "end": 0.5, "sample_interval": 0.02})
    write_scene(scene, tmp / "s.toml")
    assert main(["run", str(tmp / "s.toml"), "--out", str(tmp / "run"), "--quiet"]) == 0
    return tmp / "run"


def test_global_volume_fraction_of_the_paper_scenes():
    """Paper Table 1.1 / SPEC §2: v-bar including half of every wall disk. SPEC quotes the cell
    area as 0.16670 m^2, which gives the paper's values to four digits; pi (R_o^2 - R_i^2) with
    the stated radii is 0.166643 m^2 (0.034 % less), which raises v-bar by 2.7e-4: so three
    digits here, all three runs off by the same amount."""
    for name, paper in (("A", 0.8084), ("B", 0.8149), ("C", 0.8194)):
        scene = load_scene(ROOT / "run_scripts" / "scenes" / f"couette_{name}.toml")
        assert global_volume_fraction(scene) == pytest.approx(paper * 0.16670 / 0.166643,
                                                              abs=6e-5), name


def test_plot_writes_every_figure(small_run, tmp_path):
    from PIL import Image

    assert main(["plot", str(small_run), "--out", str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.glob("*.png"))
    assert len(names) == 10 and sum(n.startswith("fig_1_") for n in names) == 8
    for name in names:
        img = np.asarray(Image.open(tmp_path / name).convert("RGB"))
        assert img.shape[0] > 300 and img.shape[1] > 300, name
        assert len(np.unique(img.reshape(-1, 3), axis=0)) > 20, f"{name} looks blank"


def test_plot_without_rings_names_the_problem(tmp_path, capsys):
    assert main(["plot", str(tmp_path)]) == 2
    assert "no rings.h5" in capsys.readouterr().err


def test_torque_metrics_agree_with_the_fields(small_run):
    """The report's per-sample torques (from the raw sums) reproduce the time-averaged field
    and its block errors, which RingAverager computes by another route (derived fields of
    block-averaged sums)."""
    run = load_run(small_run)
    f = run["rings"]
    per_sample = ring_torques(run)
    mean, err = block_mean(per_sample)
    np.testing.assert_allclose(mean, f["shear_torque"], rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(err, f["shear_torque_err"], rtol=1e-8, atol=1e-15)
    m = metrics(run)  # the cell is 5 d~ wide: the paper's outer regions are empty (NaN)
    for key in ("fit_s", "shear_torque_mean", "shear_torque_chi2", "shear_torque_chi2_window",
                "stiffness_excess", "angle_F", "ordering_fraction", "inner_torque"):
        assert np.isfinite(m[key]), key
    assert np.isnan(m["nu_bulk"]) and np.isfinite(m["mu_c_outer"])
    assert m["inner_torque"] > 0 and m["shear_torque_mean"] > 0
    # the outer ring holds the packing back and is pushed outwards; the window holds one
    # snapshot (t = 0.5 s): no dL/dt, so no residual of the cell's balance
    assert m["outer_torque"] < 0 < m["outer_radial_force"] and m["outer_torque_err"] > 0
    assert np.isfinite(m["torque_imbalance"]) and np.isfinite(m["bottom_torque_cell"])
    assert np.isnan(m["angular_momentum_rate"]) and np.isnan(m["torque_balance_residual"])
    assert f"ring loads over {f['times'].size} samples" in (small_run / "log.txt").read_text()
    f = run["rings"]
    has = f["C"] > 0
    # tr F over nu times the contacts per particle: a volume-weighted over a number-weighted
    # mean of the same counts, so within the extreme volume ratio of the two species,
    # (7.42/8.99)^2
    bound = (7.42 / 8.99) ** 2
    ratio = f["tr_F"][has] / (f["nu"][has] * f["C_number"][has])
    assert np.all((ratio >= bound - 1e-12) & (ratio <= 1 / bound + 1e-12))
    assert m["trF_over_nuC_rms"] > 0  # no longer an identity


def test_paper_figures_script_writes_figures_table_and_json(small_run, tmp_path):
    """run_scripts/paper/paper_figures.py end to end on one run: figures, the generated table, the
    JSON of every metric (plain numbers) and the resolved scene."""
    import json
    import sys

    sys.path.insert(0, str(ROOT / "run_scripts" / "paper"))
    import paper_figures

    assert paper_figures.main([str(small_run), "--results", str(tmp_path)]) == 0
    assert len(list((tmp_path / "figures").glob("*.png"))) == 10
    table = (tmp_path / "comparison.md").read_text()
    assert "decay length s" in table and "torque of the inner ring" in table
    data = json.loads((tmp_path / "comparison.json").read_text())
    (name,) = data["ours"]
    ours = data["ours"][name]
    assert ours.pop("seeds") == 1
    assert all(isinstance(v, float) for v in ours.values())  # NaN allowed:
    # a quantity the short run cannot measure (here the bulk volume fraction) is NaN, not absent
    assert len(list((tmp_path / "scenes").glob("*.toml"))) == 1
    assert "## What the paper states, against ours" in table


def test_seeds_of_one_simulation_are_averaged_with_their_error(small_run, tmp_path):
    """Two folders named as one simulation form a group: each number is the mean of the
    folders' own metrics (computed here one by one), with the seed standard error."""
    import json
    import shutil
    import sys

    import h5py

    sys.path.insert(0, str(ROOT / "run_scripts" / "paper"))
    import paper_figures

    from averaging.report import load_run, metrics

    other = tmp_path / "seed2"
    shutil.copytree(small_run, other)
    with h5py.File(other / "rings.h5", "r+") as h5:  # another seed: the inner torque doubled
        h5["fields/inner_torque"][()] = 2 * h5["fields/inner_torque"][()]
    each = [metrics(load_run(d))["inner_torque"] for d in (small_run, other)]
    out = tmp_path / "res"
    assert paper_figures.main([str(small_run), str(other), "--results", str(out),
                               "--names", "B", "B"]) == 0
    ours = json.loads((out / "comparison.json").read_text())["ours"]["B"]
    assert ours["seeds"] == 2
    assert ours["inner_torque"] == pytest.approx(0.5 * (each[0] + each[1]))
    # standard error of the mean of two values: |a - b| / 2
    assert ours["inner_torque_err"] == pytest.approx(abs(each[0] - each[1]) / 2)


def test_runs_are_labelled_by_folder_and_compared_with_the_paper_only_when_they_are_its_scenes(
        small_run, tmp_path):
    """Two folders of one scene get their own labels; a scene merely named like the paper's
    ("my-B") is not compared with the paper's B; the shipped couette-B is."""
    import shutil

    other = tmp_path / "second"
    shutil.copytree(small_run, other)
    a, b = load_run(small_run), load_run(other)
    assert (a["label"], b["label"]) == ("run", "second") and a["paper"] is None
    assert load_run(small_run, label="dense")["label"] == "dense"
    scene = load_scene(small_run / "scene.toml")
    for name, paper in (("my-B", None), ("couette-B", "B")):
        renamed = tmp_path / name
        shutil.copytree(small_run, renamed)
        text = (renamed / "scene.toml").read_text().replace(
            f'name = "{scene.info.name}"', f'name = "{name}"')
        (renamed / "scene.toml").write_text(text)
        assert load_run(renamed)["paper"] == paper, name
    assert main(["plot", str(small_run), str(other), "--label", "one", "two", "--out",
                 str(tmp_path / "f")]) == 0
    assert main(["plot", str(small_run), "--label", "a", "b"]) == 2


def test_bottom_torque_sums_the_friction_of_the_moving_disks_inside_each_ring(small_run):
    """mu_b m g r v_phi/|v| summed by hand over the free disks inside each ring edge of the
    snapshots in the window; positive (the band turns with the ring, Omega > 0); 0 when the
    scene has no bottom friction."""
    from averaging.report import bottom_torque
    from pardem.output.snapshots import read_snapshots

    run = load_run(small_run)
    scene = load_scene(small_run / "scene.toml")
    r_tilde = np.array([1.0, 2.0, 3.0])
    lo, hi = run["window"]
    by_hand = []
    for snap in read_snapshots(small_run):
        if not lo <= snap["time"] <= hi:
            continue
        total = np.zeros(r_tilde.size)
        for k in np.flatnonzero(snap["kind"] == 0):
            (x, y), (vx, vy) = snap["position"][k], snap["velocity"][k]
            speed, r = np.hypot(vx, vy), np.hypot(x, y)
            if speed == 0:
                continue
            t = scene.contact.mu_bottom * scene.contact.gravity * snap["mass"][k] * (
                x * vy - y * vx) / speed
            total += t * (r <= run["r_in"] + r_tilde * run["d_ref"])
        by_hand.append(total.mean())
    assert by_hand and bottom_torque(run, r_tilde) == pytest.approx(np.mean(by_hand), rel=1e-9)
    assert bottom_torque(run, r_tilde) > 0
    assert bottom_torque({**run, "bottom": 0.0}, r_tilde) == 0.0

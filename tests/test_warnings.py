"""Physical sanity warnings (docs/warnings.md): each names the value and why it is suspicious,
is logged and written to stderr, never stops a run, and is set or silenced by its [warnings]
key. The 4-rank oversubscription run is in test_mpi.py."""

import math
import os
import re
from pathlib import Path

import pytest
from helpers import D_LARGE, D_SMALL, M_LARGE, M_SMALL, couette_scene

from pardem.cli import main
from pardem.input.scene import SceneError
from pardem.input.scene_file import write_scene
from pardem.input.schema import scene_from_dict
from pardem.output import warnings as run_warnings
from pardem.parallel import most_crowded_node
from pardem.simulation import Simulation

SHIPPED = Path(__file__).parents[1] / "run_scripts" / "scenes"
N_FILE, R_OUT = 44, 0.05  # disks in the file, final outer radius (m)


def squeezed_file(overlap=None, name="squeezed"):
    """A single file of N_FILE small disks squeezed into a ring 1.01 diameters wide, too short
    for them: frictionless, they end evenly spaced against the outer ring (the inner one is
    out of reach), every neighbour pair overlapping by the same depth."""
    g = {"inner_radius": R_OUT - 1.01 * D_SMALL, "outer_radius": R_OUT,
         "outer_start_radius": 0.08, "compression_time": 0.5, "omega_inner": 0.0,
         "inner_wall_count": 0, "outer_wall_count": 0}
    d = couette_scene(counts=(N_FILE, 0), geometry=g, name=name, time={"end": 1.0},
                      contact={"mu": 0.0, "mu_bottom": 0.0},
                      output={"snapshot_interval": 0.5, "contacts": False}).to_dict()
    if overlap is not None:
        d["warnings"] = {"overlap": overlap}
    return scene_from_dict(d)


def file_overlap() -> float:
    """The static pair overlap over d of squeezed_file: the centres lie on a circle of radius
    R_c = R_o - a + w, pressed a depth w into the outer ring by the outward sum of the two
    neighbours' forces, k w = 2 k delta sin(pi/N) (one k_n for both contacts); neighbours are
    2 R_c s apart (s = sin(pi/N)), so delta = d - 2 R_c s = (d - 2 (R_o - a) s) / (1 + 4 s^2)."""
    s = math.sin(math.pi / N_FILE)
    return (D_SMALL - 2 * (R_OUT - D_SMALL / 2) * s) / (1 + 4 * s * s) / D_SMALL


def overlap_warnings(text: str) -> list[tuple[float, str, float]]:
    """(time s, phase, overlap / d) of each overlap warning in ``text``."""
    return [(float(t), phase, float(pct) / 100) for t, phase, pct in re.findall(
        r"warning: t = (\S+) s, during the (\w+).*?the largest overlap is (\S+) % of", text)]


def test_a_run_squeezed_to_a_tenth_of_d_warns_once_in_the_compression_and_once_after(
        tmp_path, capsys):
    expected = file_overlap()
    assert 0.10 < expected < 0.11
    path = tmp_path / "squeezed.toml"
    write_scene(squeezed_file(), path)
    assert main(["run", str(path), "--out", str(tmp_path / "run"), "--quiet"]) == 0
    err = capsys.readouterr().err
    said = overlap_warnings(err)
    assert [phase for _, phase, _ in said] == ["compression", "shear"], err
    (t_comp, _, at_comp), (t_shear, _, at_shear) = said
    assert t_comp <= 0.5 < t_shear
    # in the compression the ring's push adds to the static overlap; after it, what is left
    # is the even squeeze (a small wave still runs round the file)
    assert expected - 0.003 < at_comp < expected + 0.02
    assert at_shear == pytest.approx(expected, abs=0.003)
    assert "[warnings] overlap = 5 %" in err and "stiffen the contact (k_n" in err
    log = (tmp_path / "run" / "log.txt").read_text()
    assert overlap_warnings(log) == said


@pytest.mark.parametrize("level,phases", [(0.09, ["compression", "shear"]), (0.13, []),
                                          (False, [])])
def test_the_overlap_warning_follows_its_level_and_false_silences_it(level, phases, capsys):
    """0.09 lies below the file's static overlap (0.108), 0.13 above it and above the
    compression's transient (about 0.12 with this push)."""
    Simulation(squeezed_file(overlap=level)).run(progress=False)
    assert [phase for _, phase, _ in overlap_warnings(capsys.readouterr().err)] == phases


def heavy_large(mass_ratio=None):
    """couette_quick's two species with the large disks' mass ten times too large."""
    d = couette_scene(counts=(20, 5)).to_dict()
    d["species"][1]["mass"] = 10 * M_LARGE
    if mass_ratio is not None:
        d["warnings"] = {"mass_ratio": mass_ratio}
    return scene_from_dict(d)


def test_a_species_ten_times_too_heavy_is_named_with_its_density(tmp_path, capsys):
    path = tmp_path / "heavy.toml"
    write_scene(heavy_large(), path)
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    rho_small = M_SMALL / (math.pi * D_SMALL**2 / 4)
    rho_large = 10 * M_LARGE / (math.pi * D_LARGE**2 / 4)
    assert 3 < rho_large / rho_small  # the paper's own masses are 1.21 apart
    assert f"2D densities m / (pi a^2) {rho_large / rho_small:.3g} x apart" in out
    assert (f"'large' (mass {10 * M_LARGE:.4g} kg, diameter {D_LARGE * 1e3:.4g} mm: "
            f"{rho_large:.4g} kg/m^2) against 'small'") in out
    assert f"{rho_small:.4g} kg/m^2" in out


@pytest.mark.parametrize("mass_ratio,warned", [(None, True), (20.0, False), (False, False)])
def test_the_mass_warning_is_set_and_silenced_by_mass_ratio(mass_ratio, warned, tmp_path,
                                                            capsys):
    """A run gives it too, logged; 12.1 x lies within mass_ratio = 20."""
    sim = Simulation(heavy_large(mass_ratio), out_dir=tmp_path)
    sim.run(end=2 * sim.dt, progress=False)
    err = capsys.readouterr().err
    assert ("pardem: warning: [[species]] masses imply" in err) == warned
    assert ("warning: [[species]] masses" in (tmp_path / "log.txt").read_text()) == warned


def test_the_paper_species_do_not_warn(capsys):
    assert main(["check", str(SHIPPED / "couette_B.toml")]) == 0
    assert "# warning" not in capsys.readouterr().out


def test_one_process_counts_the_cores_it_may_run_on():
    assert most_crowded_node(None) == (1, len(os.sched_getaffinity(0)))
    assert run_warnings.oversubscription_warning(2, 2) is None
    text = run_warnings.oversubscription_warning(4, 2)
    assert text.startswith("4 ranks share 2 cores on one node") and "at most 2 ranks" in text


@pytest.mark.parametrize("oversubscribe,warned", [(False, True), (True, False)])
def test_oversubscribe_true_silences_the_ranks_warning(oversubscribe, warned, monkeypatch,
                                                       capsys):
    """The node census is MPI's (test_mpi.py runs 4 ranks on 2 cores); here a node of 4 ranks
    on 2 cores is given to one process, to check what the key does with it."""
    monkeypatch.setattr(run_warnings, "most_crowded_node", lambda comm: (4, 2))
    d = squeezed_file(overlap=False).to_dict()
    d["warnings"]["oversubscribe"] = oversubscribe
    sim = Simulation(scene_from_dict(d))
    sim.run(end=2 * sim.dt, progress=False)
    assert ("4 ranks share 2 cores" in capsys.readouterr().err) == warned


@pytest.mark.parametrize("table,message", [
    ({"overlap": True}, "[warnings] overlap = true: expected a number or false (off)"),
    ({"overlap": 0.3}, "[warnings] overlap = 0.3: must be <= 0.25"),
    ({"mass_ratio": 1}, "[warnings] mass_ratio = 1: must be > 1"),
    ({"oversubscribe": "yes"}, "[warnings] oversubscribe = 'yes': expected a boolean"),
    ({"overlaps": 0.1}, "[warnings] unknown key 'overlaps'; allowed: overlap, mass_ratio"),
])
def test_bad_warning_keys_are_refused(table, message):
    d = squeezed_file().to_dict()
    d["warnings"] = table
    with pytest.raises(SceneError) as e:
        scene_from_dict(d)
    assert message in str(e.value)


def test_warning_keys_are_not_physics():
    """A restart may change them: the fingerprint leaves them out; the resolved scene keeps
    them (false included)."""
    a, b = squeezed_file(), squeezed_file(overlap=False)
    assert a.fingerprint() == b.fingerprint() and a != b
    assert scene_from_dict(b.to_dict()).warnings.overlap is False


@pytest.mark.parametrize("load,cores,expect", [
    (3.0, 2, "a rank would get about 0.50 of a core, so expect about 22 min on 1 rank"),
    (0.5, 2, "a rank would have a core to itself, as in the reference")])
def test_check_says_how_its_estimate_was_made_and_what_the_load_does(load, cores, expect,
                                                                     monkeypatch, capsys):
    """B: 2,939 disks x 5,497,000 steps (dt = 10 ms / 230 to 239 s) = 1.616e10 particle-steps,
    646 s at 25 M/s; at load 3 on 2 cores a new process gets 2 / (3 + 1) of a core: 1292 s."""
    from pardem import check

    monkeypatch.setattr(check.os, "getloadavg", lambda: (load, 0.0, 0.0))
    monkeypatch.setattr(check, "usable_cores", lambda: frozenset(range(cores)))
    assert main(["check", str(SHIPPED / "couette_B.toml")]) == 0
    out = capsys.readouterr().out
    assert "roughly 11 min on 1 rank" in out
    assert "# the estimate is not timed here" in out and "docs/scaling.md" in out
    assert f"# this machine: {cores} cores, load average {load:.2f}" in out and expect in out

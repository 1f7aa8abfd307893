"""Small defects an adversarial review found, each reproduced: a printed limit that is itself
refused, a 150-digit percentage, "1 cores", a silent SIGTERM while compiling, an absurd
k_adhesion accepted, a branch refused for giving its masses as a density, h5py's KeyError for a
damaged rings.h5, and what a restart on several ranks promises of rings.h5."""

import math
import re
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import D_LARGE, D_SMALL, couette_scene, free_scene

from pardem.core.timestep import resolve_dt
from pardem.input.scene import SceneError
from pardem.input.schema import scene_from_dict
from pardem.output import warnings as run_warnings
from pardem.output.branch import refuse_changes

ROOT = Path(__file__).resolve().parents[1]
SCENES = Path(__file__).parent / "scenes"


def refusal(scene) -> str:
    with pytest.raises(SceneError) as e:
        resolve_dt(scene)
    return str(e.value)


# 1. a limit printed rounded to the nearest (0.00019629 s as 0.0001963 s) was refused when
# copied into the scene, and the message read "dt = 0.0001963: ... exceeds ... 0.0001963"

@pytest.mark.parametrize("contact", [{}, {"k_n": 500.0}, {"mu": 0.0}])
def test_the_printed_stability_limit_is_accepted_as_dt(contact):
    """Whatever the material, the printed dt bound and dt_per_contact bound, copied into the
    scene, are accepted: a printed bound must hold as printed."""
    text = refusal(couette_scene(counts=(100, 0), contact=contact, time={"dt": 1e-3}))
    bound = re.search(r"use dt <= ([0-9.e+-]+) s", text).group(1)
    ratio = re.search(r"dt_per_contact >= ([0-9.e+-]+)", text).group(1)
    assert f"stability limit {bound} s" in text
    assert resolve_dt(couette_scene(counts=(100, 0), contact=contact,
                                    time={"dt": float(bound)})) == float(bound)
    resolve_dt(couette_scene(counts=(100, 0), contact=contact,
                             time={"dt_per_contact": float(ratio)}))


def test_a_refused_dt_never_prints_as_the_limit_it_exceeds():
    """The paper's material: the limit is 0.00019629... s; dt = 0.0001963 lies above it and is
    refused, and the message shows the two as different numbers."""
    text = refusal(couette_scene(counts=(100, 0), time={"dt": 0.0001963}))
    given = re.match(r"\[time\] dt = ([0-9.e+-]+):", text).group(1)
    bound = re.search(r"stability limit ([0-9.e+-]+) s", text).group(1)
    assert float(given) == 0.0001963 and float(bound) < float(given), text


# 2. density = 1e300 printed the overlap as a 150-digit percentage

def test_an_absurd_density_prints_numbers_of_a_few_digits():
    """The heavy disk (density 1e300 kg/m^3) hit by the inner ring at v = omega R_i overlaps
    it by up to v sqrt(m/k_n) of its diameter (undamped spring on an infinitely heavy wall)."""
    d = couette_scene(counts=(100, 10)).to_dict()
    d["species"][1].pop("mass")
    d["species"][1]["density"] = 1e300
    text = refusal(scene_from_dict(d))
    m = 1e300 * math.pi * (D_LARGE / 2) ** 2 * 6e-3  # kg: density pi (d/2)^2 h
    share = 100 * 0.1 * 0.1035 * math.sqrt(m / 352.1) / D_LARGE  # % (omega, R_i, k_n)
    assert text.startswith("[geometry] omega_inner = 0.1:")
    assert f"{share:.3g} % of its diameter" in text, text
    assert not re.search(r"\d{12,}", text), text


# 3. "2 ranks share 1 cores ... Run at most 1 ranks per node"

@pytest.mark.parametrize("ranks, cores, shared, most", [
    (2, 1, "2 ranks share 1 core on one node", "at most 1 rank per node"),
    (5, 2, "5 ranks share 2 cores on one node", "at most 2 ranks per node")])
def test_the_oversubscription_warning_counts_in_singular_and_plural(ranks, cores, shared, most):
    text = run_warnings.oversubscription_warning(ranks, cores)
    assert text.startswith(shared) and most in text, text


# 4. SIGTERM during the set-up or a compile killed pardem run silently (-15)

FAKE_SET_UP = """
import os, signal, sys, time
import pardem.simulation

class Compiling:  # a set-up that takes long (a cold compile) and gets SIGTERM meanwhile
    def __init__(self, *args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)
        deadline = time.time() + 30
        while time.time() < deadline:
            time.sleep(0.01)
        sys.exit("the set-up ran on after SIGTERM")

pardem.simulation.Simulation = Compiling
from pardem.cli import main
sys.argv = ["pardem", "run", sys.argv[1], "--out", sys.argv[2], "--quiet"]
sys.exit(main())
"""


def test_sigterm_before_the_time_step_loop_is_one_line_and_status_143(tmp_path):
    """As a Ctrl-C there (one line, 128 + 2): 128 + 15, the shell's convention for a process
    ended by SIGTERM, and a line naming the signal instead of a silent death."""
    proc = subprocess.run([sys.executable, "-c", FAKE_SET_UP, str(SCENES / "two_small.toml"),
                           str(tmp_path / "out")], capture_output=True, text=True, timeout=120,
                          preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL))
    assert proc.returncode == 128 + signal.SIGTERM, (proc.returncode, proc.stderr)
    assert "interrupted (SIGTERM) outside the time-step loop" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr


def test_the_sigterm_handler_of_pardem_run_is_gone_after_it(tmp_path):
    """Called from Python (argv given), pardem run leaves SIGTERM's handler as it found it."""
    from pardem.cli import main

    before = signal.getsignal(signal.SIGTERM)
    assert main(["run", str(tmp_path / "missing.toml"), "--out", str(tmp_path)]) == 2
    assert signal.getsignal(signal.SIGTERM) is before


# 5. [contact] k_adhesion = 1e300 was accepted

D, M = 0.01, 1e-3  # two disks (m, kg)
LUDING = {"normal": "luding", "k_unload": 704.2}


def two_disks(dt: float, contact: dict, pair: dict | None = None):
    ps = [{"x": -D, "y": 0.0, "diameter": D, "mass": M, "species": 0},
          {"x": D, "y": 0.0, "diameter": D, "mass": M, "species": 1 if pair else 0}]
    scene = free_scene(ps, contact={**LUDING, **contact}, time={"dt": dt, "end": 0.01})
    if pair is None:
        return scene
    d = scene.to_dict()
    d["contact"]["pair"] = [{"species": [0, 1], **pair}]
    return scene_from_dict(d)


def test_an_absurd_k_adhesion_is_refused_with_the_largest_the_step_resolves():
    """On the tension branch m_red delta'' = k_adhesion delta: the step must resolve
    sqrt(m_red/k_adhesion) as a collision's pi sqrt(m_red/k) in five steps, so k_adhesion <=
    m_red (pi/(5 dt))^2 with m_red = M/2; the largest allowed value, as printed, is accepted."""
    dt = 1e-5
    most = M / 2 * (math.pi / (5 * dt)) ** 2  # N/m
    text = refusal(two_disks(dt, {"k_adhesion": 1e300}))
    assert text.startswith("[contact] k_adhesion = 1e+300: Luding's tension branch"), text
    printed = float(re.search(r"k_adhesion may be at most ([0-9.e+-]+) N/m", text).group(1))
    assert printed <= most and printed == pytest.approx(most, rel=1e-3)
    resolve_dt(two_disks(dt, {"k_adhesion": printed}))
    resolve_dt(two_disks(dt, {"k_adhesion": LUDING["k_unload"]}))
    text = refusal(two_disks(dt, {}, pair={"k_adhesion": 1e300}))
    assert text.startswith("[[contact.pair]] #0 0-1 k_adhesion = 1e+300"), text


# 6. a branch that gave the prepared run's masses as a density was refused

def species_row(s: dict, mass=None, density=None) -> dict:
    s = {k: v for k, v in s.items() if k not in ("mass", "density")}
    return {**s, **({"mass": mass} if mass is not None else {"density": density})}


def with_species(mass=None, density=None, height=6e-3):
    """The small-disk cell with the small disks' mass or density and the disk height."""
    d = couette_scene(counts=(100, 0), contact={"height": height}).to_dict()
    d["species"][0] = species_row(d["species"][0], mass, density)
    return scene_from_dict(d)


def test_a_branch_may_give_the_prepared_masses_as_a_density(tmp_path):
    """mass = density pi (d/2)^2 h (docs/input.md): the same disks either way; a density that
    gives other masses, or the same density at another height, is a particle change."""
    rho = 1200.0
    mass = rho * math.pi * (D_SMALL / 2) ** 2 * 6e-3
    prepared = with_species(mass=mass).physics()
    for branch in (with_species(density=rho), with_species(mass=mass, height=7e-3)):
        refuse_changes(tmp_path, branch.physics(), prepared, 100, 100)
    with pytest.raises(SceneError, match=r"\[\[species\]\] #0 \(small\) mass \(given, or "
                                         r"density pi \(d/2\)\^2 h"):
        refuse_changes(tmp_path, with_species(density=1.1 * rho).physics(), prepared, 100, 100)
    by_density = with_species(density=rho).physics()
    with pytest.raises(SceneError, match=r"#0 \(small\) mass .* is 0\.000311"):
        refuse_changes(tmp_path, with_species(density=rho, height=7e-3).physics(),
                       by_density, 100, 100)


def test_a_branch_from_a_run_with_masses_runs_with_the_density(tmp_path):
    from pardem.simulation import Simulation

    rho = 1200.0
    mass = rho * math.pi * (D_SMALL / 2) ** 2 * 6e-3
    prepared = Simulation(with_species(mass=mass), out_dir=tmp_path / "prepared")
    prepared.run(end=0.002, progress=False)
    branch = Simulation(with_species(density=rho), out_dir=tmp_path / "branch",
                        branch=tmp_path / "prepared")
    assert branch.step == prepared.step
    np.testing.assert_array_equal(branch.gathered("mass")["mass"][:100], mass)


# 7. ring_dataset on a damaged rings.h5 raised h5py's KeyError, naming no file

def test_a_damaged_rings_file_is_named_with_what_it_lacks(tmp_path):
    pytest.importorskip("xarray")
    from averaging.io import read_rings
    from averaging.tables import ring_dataset

    path = tmp_path / "rings.h5"
    with h5py.File(path, "w") as h5:  # a run's rings.h5 that lost its fields
        h5.create_dataset("sums", data=np.zeros((2, 3, 4)))
        h5.create_dataset("times", data=[0.1, 0.2])
    for read in (ring_dataset, read_rings):
        with pytest.raises(ValueError, match=f"{re.escape(str(path))}: damaged .* no fields/r, "
                                             "fields/r_tilde"):
            read(tmp_path)
    path.write_bytes(b"\x89HDF\r\n" + bytes(200))  # cut short: not HDF5 any more
    with pytest.raises(ValueError, match=f"{re.escape(str(path))}: not readable as HDF5"):
        ring_dataset(tmp_path)


# 8. docs/running.md promised rings.h5's bits after a restart on the same number of ranks;
# on several ranks the restart cuts the annulus anew, so the ranks' sums round differently

def test_running_md_promises_what_a_restart_keeps_of_the_ring_averages():
    text = " ".join((ROOT / "docs" / "running.md").read_text(encoding="utf-8").split())
    assert "the same bits on the same number of ranks" not in text
    assert ("On one rank the later samples and the fields are the same bits too; on several "
            "ranks (the same number or another) they agree to 1e-12 relative") in text

"""The step loop's per-stage timers (``core/timing.py``, ``pardem run --timing``): compiled in
only when asked for, disjoint parts of the compiled call's wall time, and without effect on the
trajectory. (On 2 ranks, with the refresh's parts: tests/test_regression.py.)"""

from pathlib import Path

import numba as nb
import numpy as np

from pardem.cli import main
from pardem.core.jit import JIT
from pardem.core.timing import CLOSING, DRIFT, FIRST, FORCES, REFRESH, STEPS
from pardem.input.scene_file import load_scene
from pardem.output.progress import STAGE_COLUMNS
from pardem.simulation import Simulation

SCENE = Path(__file__).parent / "scenes" / "two_small.toml"
STEPS_RUN = 3000  # through the collision (t_c = 2.2 ms, dt ~ 0.1 ms) and past it


def _asm(sim) -> str:
    """The machine code of the run's step loop, compiled again without the disk cache (whose
    code cannot be inspected) for the signature the run used."""
    advance = sim.stepper.advance
    fresh = nb.njit(**dict(JIT, cache=False))(advance.py_func)
    sig = advance.signatures[0]
    fresh.compile(sig)
    return fresh.inspect_asm(sig)


def test_timers_are_compiled_in_only_when_asked_for_and_leave_the_bits():
    plain = Simulation(load_scene(SCENE))
    timed = Simulation(load_scene(SCENE), timing=True)
    for sim in (plain, timed):
        sim.reset_timers()
        sim.advance_steps(STEPS_RUN)
    # off costs nothing: the default loop does not read the clock at all
    assert "clock_gettime" not in _asm(plain)
    assert "clock_gettime" in _asm(timed)
    assert not plain.clock.deep[FIRST:].any()
    for name in ("x", "v", "omega", "f", "tau"):
        assert np.array_equal(getattr(plain.ps, name), getattr(timed.ps, name)), name
    t = timed.clock.deep
    assert t[STEPS] == STEPS_RUN
    # one rank: no refresh code, so nothing waited for, packed or unpacked
    assert not timed.decomp.wait.any()
    stages = t[DRIFT] + t[REFRESH] + t[FORCES] + t[CLOSING]
    # disjoint intervals of the same monotonic clock inside the timed Python call
    assert 0.0 < stages <= timed.timers["forces+integration"]
    assert min(t[DRIFT], t[FORCES], t[CLOSING]) > 0.0


def test_run_with_timing_prints_the_stage_table(tmp_path, capsys):
    assert main(["run", str(SCENE), "--out", str(tmp_path), "--quiet", "--timing",
                 "--end", "0.01"]) == 0
    err = capsys.readouterr().err
    lines = err[err.index("us per step of each stage"):].splitlines()
    assert lines[1].split() == ["rank", *" ".join(STAGE_COLUMNS).split()]
    row = lines[2].split()
    assert row[0] == "0" and len(row) == 1 + len(STAGE_COLUMNS)
    figures = dict(zip(STAGE_COLUMNS, map(float, row[1:])))
    parts = sum(figures[k] for k in ("kick+drift", "refresh", "forces", "closing kick"))
    assert 0.0 < parts <= figures["step"] + 0.01  # the table rounds to 0.01 us
    assert "us per step of each stage" in (tmp_path / "log.txt").read_text()

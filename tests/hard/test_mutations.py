"""Every guard of the hard-case suite is needed: ``tests/hard/mutations.py`` removes each one in
turn and runs the test that must catch it. Marked slow (``python -m pytest -m slow``): a
mutation of compiled code starts a cold numba cache, about 12 minutes in all on a busy 2-core
machine."""

import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent


@pytest.mark.slow
@pytest.mark.timeout(7200)
def test_removing_any_guard_makes_its_test_fail():
    proc = subprocess.run([sys.executable, str(HERE / "mutations.py")], capture_output=True,
                          text=True)
    print(proc.stdout)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "NOT CAUGHT" not in proc.stdout

"""A run gives the arrays it frees back to the operating system (pardem.core.memory)."""

import subprocess
import sys

import pytest

# A 16 MB array freed first (with glibc's default this raises the mmap threshold to 16 MB), then
# twelve 8 MB arrays of which all but the newest are freed: the resident anonymous memory that
# stays, in MB, is printed.
KEEPS = """
import contextlib
import sys
import numpy as np
from pardem.core.memory import reuse_freed_arrays, unmap_freed_arrays, unmapped

def anon():
    with open("/proc/self/status") as f:
        return next(int(s.split()[1]) for s in f if s.startswith("RssAnon:")) / 1024

mode = sys.argv[1]
reuse = lambda: unmap_freed_arrays() and reuse_freed_arrays()
applied = {"unmap": unmap_freed_arrays, "reuse": reuse, "default": lambda: None,
           "exchange": reuse_freed_arrays, "kept, then an exchange": reuse}[mode]()
before = anon()
with unmapped() if mode == "exchange" else contextlib.nullcontext():
    a = np.ones(2 * 2**20)
    del a
    kept = [np.ones(2**20) for _ in range(12)]
    del kept[:-1]
if mode == "kept, then an exchange":  # an exchange starts with what the builds left
    with unmapped():
        pass
print(applied, anon() - before - 8)
"""


def _kept_mb(mode: str) -> tuple[str, float]:
    out = subprocess.run([sys.executable, "-c", KEEPS, mode], capture_output=True, text=True,
                         check=True).stdout.split()
    return out[0], float(out[1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc, glibc's malloc")
def test_freed_arrays_leave_the_resident_set_in_the_set_up_and_exchanges_only():
    """Eleven freed 8 MB arrays are 88 MB: with glibc's default heap most of them stay resident
    (the control, which shows the measure can tell); after ``unmap_freed_arrays`` (the set-up)
    and inside ``unmapped()`` (an exchange) none does; after ``reuse_freed_arrays`` (the
    builds between exchanges) they stay for reuse again, until an exchange begins."""
    applied, kept = _kept_mb("unmap")
    if applied != "True":
        pytest.skip("the C library is not glibc (mallopt refused)")
    assert kept < 8.0, kept
    assert _kept_mb("exchange")[1] < 8.0
    # the blocks the heap kept for reuse are given back when an exchange begins, so that the
    # exchange's arrays do not come on top of them
    assert _kept_mb("kept, then an exchange")[1] < 8.0
    for mode in ("default", "reuse"):
        applied, kept = _kept_mb(mode)
        assert kept > 60.0, (mode, kept)
        assert applied == {"default": "None", "reuse": "True"}[mode]

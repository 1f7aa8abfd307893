"""Compilation a user can see (pardem/compile_watch.py): while numba compiles, progress lines
name the kernel and the time so far; the total is kept for the next estimate; kernels that are
already compiled print nothing."""

import numba as nb
import numpy as np

from pardem.compile_watch import CompileWatch, kernel_name, last_compile
from pardem.core.forces import contact_forces


def fresh_kernel():
    """A kernel numba has not compiled yet (a new function object each call, no disk cache),
    large enough that its compile spans several progress intervals."""
    def kernel(x):
        total = 0.0
        for i in range(x.size):
            total += np.sin(x[i]) * np.cos(x[i]) + np.sqrt(abs(x[i]))
        return total
    return nb.njit(kernel)


def test_a_compile_prints_progress_and_is_remembered(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    lines = []
    label = '{"effects": "test"}'
    assert last_compile(label) is None
    with CompileWatch(label, report=lines.append, interval=0.01) as watch:
        assert "the first compile of this set of effects here" in watch.plan()
        fresh_kernel()(np.ones(3))
    assert watch.kernels >= 1 and watch.seconds > 0.0
    progress = [line for line in lines if "compiling" in line]
    assert progress, lines
    assert "test_compile_watch.kernel" in progress[-1] and "kernels done" in progress[-1]
    assert lines[-1].startswith(f"pardem: compiled {watch.kernels} kernels in")
    assert last_compile(label) == round(watch.seconds, 1)
    # the next compile of the same set knows how long the last one took
    again = CompileWatch(label, report=None)
    assert f"took {watch.seconds:.0f} s" in again.plan()
    assert "left (last time" in again.plan(spent=watch.seconds / 2)


def test_kernels_already_compiled_print_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    kernel = fresh_kernel()
    kernel(np.ones(3))
    lines = []
    with CompileWatch("{}", report=lines.append, interval=0.01) as watch:
        kernel(np.ones(5))
    assert watch.kernels == 0 and lines == [] and last_compile("{}") is None


def test_a_kernel_is_named_by_its_group():
    assert kernel_name(contact_forces) == "the contact forces (forces.contact_forces)"

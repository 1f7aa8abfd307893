"""Compilation a user can see: which kernels numba is compiling, for how long so far, and how
long the last cold compile of the same set of kernels took on this machine.

Stage: entry point (``pardem run`` and ``pardem warmup``). numba compiles a kernel at its first
call, or loads it from the disk cache (quick, and silent here). A compile fires numba's
``"numba:compile"`` event; ``CompileWatch`` listens to it. While compiling has gone on for
``interval`` seconds, a daemon thread prints one line every ``interval`` seconds: the kernel
being compiled (its group and name), the compile time so far and, from the last cold compile
of the same set on this machine, the time left. At the end it prints the total and keeps it
(``compile_times.json`` beside the numba cache folders, keyed by ``compile_label``). A run whose
kernels all come from the cache prints nothing.

The thread takes the GIL between numba's Python-level compiler passes and while LLVM works in
C (llvmlite releases it), so its lines come on time.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Callable

from numba.core import event

from .core.jit import cache_base

GROUPS = (("pardem.core.step", "the step loop"), ("pardem.core.forces", "the contact forces"),
          ("pardem.core.pair_select", "the contact forces"),
          ("pardem.contact", "the contact law"), ("pardem.core.neighbors", "the neighbour lists"),
          ("pardem.core.integrate", "the integrator"), ("pardem.boundaries", "the boundaries"),
          ("pardem.parallel", "the MPI exchange"), ("pardem.core.diagnostics", "the diagnostics"),
          ("averaging", "the ring averages"), ("pardem", "the set-up"))
"""Kernel groups by module prefix, the first match naming a kernel's group."""


def kernel_name(dispatcher) -> str:
    """``group (module.function)`` of a numba dispatcher."""
    module = dispatcher.py_func.__module__
    group = next((g for prefix, g in GROUPS if module.startswith(prefix)), module)
    return f"{group} ({module.rpartition('.')[2]}.{dispatcher.py_func.__name__})"


def compile_label(scene, ranks: int) -> str:
    """What decides which kernels a run compiles: the scene's kind, effects, normal law,
    integrator, whether it has pair tables and averaging, and the number of ranks."""
    return json.dumps({"kind": scene.info.kind, "effects": dataclasses.asdict(scene.effects),
                       "normal": scene.contact.normal, "integrator": scene.time.integrator,
                       "pairs": bool(scene.pairs), "averaging": scene.averaging is not None,
                       "ranks": ranks}, sort_keys=True)


def _history_file() -> Path:
    return cache_base() / "compile_times.json"


def last_compile(label: str) -> float | None:
    """Seconds the last cold compile of ``label`` took on this machine, None if unknown."""
    try:
        return float(json.loads(_history_file().read_text())[label])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _remember(label: str, seconds: float) -> None:
    """Keep ``seconds`` for ``label`` (written whole: a temporary file, then renamed)."""
    path = _history_file()
    try:
        table = json.loads(path.read_text())
    except (OSError, ValueError):
        table = {}
    table[label] = round(seconds, 1)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".compile_times")
        with os.fdopen(fd, "w") as f:
            json.dump(table, f, indent=1, sort_keys=True)
        os.replace(tmp, path)
    except OSError:  # no writable cache: the estimate is only missing next time
        pass


def _stderr(line: str) -> None:
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


class CompileWatch(event.Listener):
    """Context manager: report numba's compiles within it (see the module's docstring).
    ``label``: compile_label; ``report``: where lines go (None: nowhere, e.g. on ranks other
    than 0, which still time their compiles); ``interval``: seconds between lines."""

    def __init__(self, label: str, report: Callable[[str], None] | None = _stderr,
                 interval: float = 10.0, remember: bool = True) -> None:
        self.label, self.report, self.interval, self.remember = label, report, interval, remember
        self.expected = last_compile(label)
        self.seconds = 0.0  # compiling finished so far
        self.kernels = 0
        self.reported = 0  # kernels the caller has reported (the summary counts the rest)
        self._depth, self._since, self._current = 0, 0.0, ""
        self._lock = threading.Lock()
        self._stop = threading.Event()

    # numba's events (the compiling thread)
    def on_start(self, ev) -> None:
        with self._lock:
            if self._depth == 0:
                self._since = time.perf_counter()
            self._depth += 1
            self._current = kernel_name(ev.data["dispatcher"])

    def on_end(self, ev) -> None:
        with self._lock:
            self._depth -= 1
            self.kernels += 1
            if self._depth == 0:
                self.seconds += time.perf_counter() - self._since

    def elapsed(self) -> float:
        """Seconds spent compiling so far, the compile under way included."""
        with self._lock:
            return self.seconds + (time.perf_counter() - self._since if self._depth else 0.0)

    def plan(self, spent: float = 0.0) -> str:
        """What the last cold compile of this set says, after ``spent`` s of compiling."""
        if self.expected is None:
            return "the first compile of this set of effects here: 0.5-2 min"
        last = f"the last cold compile of this set of effects here took {self.expected:.0f} s"
        if not spent:
            return last
        return (f"~{self.expected - spent:.0f} s left (last time {self.expected:.0f} s)"
                if spent < self.expected else f"longer than last time ({self.expected:.0f} s)")

    def line(self) -> str:
        """The progress line while compiling."""
        spent = self.elapsed()
        return (f"pardem: compiling {self._current}: {spent:.0f} s, {self.kernels} kernels "
                f"done; {self.plan(spent)}")

    def _watch(self) -> None:
        while not self._stop.wait(self.interval):
            if self._depth and self.elapsed() >= self.interval and self.report:
                self.report(self.line())

    def __enter__(self) -> CompileWatch:
        event.register("numba:compile", self)
        self._thread = threading.Thread(target=self._watch, daemon=True, name="compile-watch")
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()
        event.unregister("numba:compile", self)
        if self.kernels and exc[0] is None:
            # a compile far shorter than the last was partial (most kernels came from the
            # cache): it would make the next estimate wrong
            if self.remember and self.seconds >= 0.5 * (self.expected or 0.0):
                _remember(self.label, self.seconds)
            if self.report and self.kernels > self.reported:
                self.report(f"pardem: compiled {self.kernels} kernels in {self.seconds:.0f} s, "
                            "cached for the next runs of this set of effects")

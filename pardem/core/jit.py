"""Numba compilation options shared by every kernel (one decision, one place), and where the
compiled code is cached.

- ``cache=True``: compiled code is stored on disk and served to later processes (warm start).
- ``error_model="numpy"``: float division by zero gives inf/nan instead of a Python exception,
  so hot loops carry no exception branches; the step loop's NaN watchdog catches the result.
- No fastmath: "nnan"/"ninf" would remove the NaN watchdog; FMA contraction breaks the exact
  antisymmetry of pair forces (a_i w_i + a_j w_j becomes fma(a_i, w_i, a_j w_j), not symmetric
  in i <-> j); and "arcp" lets LLVM round a division differently in differently specialised
  kernels, so mu = 0 no longer reproduces tangential_friction = false bit for bit. Both were
  measured (tests/test_contact_law.py, tests/test_effects.py); the speed gain was ~1-2 %.
- ``INLINE`` kernels are inlined into their caller at numba IR level: the contact law into the
  force loop's lanes (so that LLVM vectorises them), the integrator's kick and drift into the
  step loop. numba copies the callee's IR for every call site, at a cost that grows with its
  size (~20 s of the cold compile when the whole force loop was inlined into the step loop),
  so large kernels are called instead and get their switches from ``static.py``. A caller must
  not reuse a variable name of an inlined callee: that was seen to change results by 1 ulp
  (tests/test_contact_law.py compares the compiled loop with standalone kernel calls).
- Compiled code assigns arrays element by element (``copy_values``), never ``a[i:j] = b``: see
  there. ``run_scripts/benchmarks/compile_times.py`` measures the cold compile per module.

The cache: numba keys a cached function by its own source file only, so a step loop that
inlines a kernel from another file would keep serving stale code after that file changed.
Unless NUMBA_CACHE_DIR is set, the cache therefore lives in a folder named after a hash of every
source file of pardem and averaging that uses numba (~/.cache/pardem/numba/<hash>; folders
unused for a day are removed, the newest few kept): any edit of compiled code starts a fresh
cache.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import time
from pathlib import Path

JIT = dict(cache=True, error_model="numpy")
INLINE = dict(JIT, inline="always")
KEEP_CACHES = 8


def kernel_sources() -> list[Path]:
    """Every source file of pardem and averaging that uses numba, in a fixed order: what the
    cache folder's name is a hash of."""
    root = Path(__file__).resolve().parents[2]  # the folder holding pardem/ and averaging/
    return [path for package in ("pardem", "averaging")
            for path in sorted((root / package).rglob("*.py")) if b"numba" in path.read_bytes()]


def _source_keyed_cache() -> None:
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    sources = kernel_sources()
    if not sources:  # a moved jit.py hashing nothing would share one cache among versions
        raise RuntimeError(f"no kernel sources found from {__file__}")
    root = Path(__file__).resolve().parents[2]
    digest = hashlib.sha1()
    for path in sources:
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pardem" / "numba"
    folder = base / digest.hexdigest()[:16]
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)
        old = sorted(base.iterdir(), key=lambda p: p.stat().st_mtime)[:-KEEP_CACHES]
        for path in old:
            if time.time() - path.stat().st_mtime > 86400:
                shutil.rmtree(path, ignore_errors=True)
    except OSError:  # no writable home: numba's default (__pycache__ beside the sources)
        return
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    import numba

    numba.core.config.reload_config()


_source_keyed_cache()

import numba  # noqa: E402  (after the cache folder is chosen: kernels cache there)


@numba.njit(**JIT)
def copy_values(dst, src):
    """dst[k] = src[k] for every k of the 1-D ``src`` (compiled code). An array assigned to a
    slice (``dst[a:b] = src``) would pull in numba's shape-mismatch error message, whose string
    formatting costs seconds of every cold compile."""
    for k in range(src.size):
        dst[k] = src[k]

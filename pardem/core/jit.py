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
Unless NUMBA_CACHE_DIR is set, the cache therefore lives in a folder named after a hash of what
compiled code depends on (``kernel_sources``: the modules that define kernels and those they
import; ~/.cache/pardem/numba/<hash>; folders unused for a day are removed, the newest few
kept): any edit of compiled code starts a fresh cache, an edit of the front end does not.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import time
from pathlib import Path

JIT = dict(cache=True, error_model="numpy")
INLINE = dict(JIT, inline="always")
KEEP_CACHES = 8


_IMPORT = re.compile(rb"^[ \t]*(?:from[ \t]+([.\w]+)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*)"
                     rb"|import[ \t]+([\w.]+))", re.M)


_KERNELS = re.compile(rb"njit|numba\.extending|intrinsic")


def _imports(path: Path, name: str, modules: dict) -> set:
    """The package modules that module ``name`` (file ``path``) imports, at any level."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for source, names, plain in _IMPORT.findall(path.read_bytes()):
        base = (source or plain).decode()
        if base.startswith("."):
            dots = len(base) - len(base.lstrip("."))
            parts = package.split(".")[:len(package.split(".")) - dots + 1]
            base = ".".join(parts + ([base[dots:]] if base[dots:] else []))
        found |= {base} & modules.keys()
        for item in re.findall(rb"\w+", names.split(b"#")[0] if b"(" not in names else names):
            found |= {f"{base}.{item.decode()}"} & modules.keys()
    return found


def kernel_sources(root: Path | None = None) -> list[Path]:
    """What compiled code depends on, in a fixed order: every module of pardem and averaging
    that defines compiled code (jitted functions, numba types, intrinsics), and every package
    module one of them imports (the constants, types and values its kernels read: a value a
    kernel reads is defined there, not further down). The cache folder's name is a hash of
    them, so that an edit of the front end (the CLI, the run loop, the output, the
    averaging's reports) keeps the cache."""
    root = root or Path(__file__).resolve().parents[2]  # the folder of pardem/, averaging/
    modules = {".".join(p.relative_to(root).with_suffix("").parts).removesuffix(".__init__"): p
               for package in ("pardem", "averaging")
               for p in sorted((root / package).rglob("*.py"))}
    kernels = {name for name, path in modules.items() if _KERNELS.search(path.read_bytes())}
    needed = kernels.union(*(_imports(modules[name], name, modules) for name in kernels))
    return sorted((modules[name] for name in needed), key=lambda p: p.relative_to(root).parts)


def kernel_key(root: Path | None = None) -> str:
    """The hash of ``kernel_sources`` (paths and contents) that names the cache folder."""
    root = root or Path(__file__).resolve().parents[2]
    sources = kernel_sources(root)
    if not sources:  # a moved jit.py hashing nothing would share one cache among versions
        raise RuntimeError(f"no kernel sources found from {__file__}")
    digest = hashlib.sha1()
    for path in sources:
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def cache_base() -> Path:
    """The folder of pardem's numba caches (one subfolder per kernel-source hash)."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pardem" / "numba"


def _source_keyed_cache() -> None:
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    base = cache_base()
    folder = base / kernel_key()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)
        old = sorted((p for p in base.iterdir() if p.is_dir()),
                     key=lambda p: p.stat().st_mtime)[:-KEEP_CACHES]
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

"""Memory a scene needs, checked before anything is allocated, and a heap that gives freed arrays
back.

Stage: set-up. Every rank places the whole cell (positions, radii, masses of every particle:
the sectors are cut from them) and then builds the arrays of its own share only, so a rank's
peak is at most about ``BYTES_PER_PARTICLE`` times the scene's total particle count (wall disks
included) plus the interpreter and the compiled kernels, on any number of ranks. A scene that
cannot fit in the memory the node has available for its ranks is refused with the numbers,
instead of a MemoryError (or the kernel's out-of-memory killer) somewhere in the placement.

glibc's malloc serves a block of at least M_MMAP_THRESHOLD bytes with a mapping of its own and
unmaps it when the block is freed, but by default it raises that threshold to the largest such
block freed so far (up to 32 MiB). The set-up (placement or restart, cut, first exchange and
build) frees large arrays of many sizes, which the heap would keep and fragment: the set-up runs
with a fixed threshold that unmaps them (``unmap_freed_arrays``). The steps then make arrays of
the same few sizes at every build, which the heap reuses without touching new pages
(``reuse_freed_arrays``, glibc's own policy once it has grown); only an exchange, every few
builds, gives its blocks back (``unmapped``): they have sizes no build makes, so the heap would
grow by them once more. It first returns the builds' blocks the heap kept, so that its arrays do
not come on top of them (``give_back_free_heap``; the next build maps its blocks again).
Unmapped, each build's temporaries would cost fresh pages (7-13 % more time at 1M disks building
every 16 steps, for 2 % less memory). At 1M disks on 2 ranks in a dense packing (600 steps, 37
builds, 6 exchanges) the set-up's peak fell from 540-552 to 465-473 MB per rank and the steps'
from 556-560 to 472-477 MB, ~940 B per owned disk; in its loose, sheared state at 8 s the busiest
rank's peak fell from 1,060-1,069 to 983-992 B per owned disk with the trim before exchanges and
lighter merges of the contact history (docs/scaling.md).
"""

from __future__ import annotations

import ctypes
import math
import resource
from contextlib import contextmanager
from pathlib import Path

from ..boundaries.registry import wall_disk_count
from ..parallel import size_of, smallest_node_share
from ..input.scene import Scene, SceneError

BYTES_PER_PARTICLE = 600
"""Peak resident bytes per particle of the whole cell, per rank, at set-up and in the first
steps, above the imports (124 MB): measured for the scaled couette_B at 300k and 1M disks 475
and 357 B on 1 rank, 471 and 408 B per rank on 2 (``max RSS``; the placement's lattice and the
first exchange's copies were the peak; the first exchange now writes in place: ~310 B per rank
on 2 at 1M), rounded up for the neighbour lists of a dense packing."""

BASE_BYTES = 200e6
"""The interpreter, numpy, numba and the loaded kernels (measured 110 MB), rounded up."""


def particle_count(scene: Scene) -> int:
    """Free particles plus wall disks."""
    return scene.n_free + wall_disk_count(scene)


def needed_bytes(scene: Scene) -> float:
    """Estimated peak bytes of one rank: the particles and the in-situ averaging."""
    return BASE_BYTES + BYTES_PER_PARTICLE * float(particle_count(scene)) + averaging_bytes(scene)


def averaging_shape(scene: Scene) -> tuple[int, int]:
    """(samples, rings) of the scene's in-situ averaging up to its [time] end; (0, 0)
    without one. The samples as the grid of output/writers.py counts them, to a sample."""
    from ..sampling import ring_width

    cfg, g = scene.averaging, scene.geometry
    if cfg is None or g is None:
        return 0, 0
    rings = max(math.ceil((g.outer_radius - g.inner_radius) / ring_width(scene) - 1e-9), 1)
    last = min(cfg.end, scene.time.end)
    samples = (math.floor((last - cfg.start) / cfg.sample_interval + 1e-9) + 1
               if last >= cfg.start else 0)
    return samples, rings


def averaging_bytes(scene: Scene) -> float:
    """Peak bytes of the in-situ averaging on one rank. Every rank keeps every sample's ring
    sums (reduced over the ranks), rings x ``N_COLUMNS`` numbers each, and stacks them once
    more while it forms the fields or writes a checkpoint. At the end it forms every field
    (``FIELDS``) of the whole window and of each block of samples its errors come from, and
    rings.vtu repeats each ring's fields in its segments (averaging/mesh.py)."""
    samples, rings = averaging_shape(scene)
    if not samples:
        return 0.0
    from averaging.fields import FIELDS, N_COLUMNS  # averaging builds on pardem
    from averaging.mesh import VTU_BYTES_PER_CELL, segments_for
    from averaging.timeavg import ERROR_BLOCKS

    blocks = min(ERROR_BLOCKS, samples)
    return (2.0 * 8.0 * samples * rings * N_COLUMNS
            + 8.0 * (blocks + 1) * len(FIELDS) * rings
            + VTU_BYTES_PER_CELL * float(rings * segments_for(rings)))


def available_bytes() -> float | None:
    """Memory available for new allocations: MemAvailable, or less inside a cgroup with a
    limit (a container, a batch job: memory.max - memory.current); None where neither file
    exists."""
    found = []
    try:
        with open("/proc/meminfo") as f:
            found += [1024.0 * float(line.split()[1]) for line in f
                      if line.startswith("MemAvailable:")]
    except OSError:
        pass
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if limit != "max":
            found.append(float(limit) - float(Path("/sys/fs/cgroup/memory.current").read_text()))
    except (OSError, ValueError):
        pass
    return min(found) if found else None


M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
"""mallopt's parameter numbers (glibc's malloc.h)."""

MMAP_THRESHOLD = 1 << 20
"""Bytes from which a block of the set-up or of an exchange is mapped on its own and unmapped
when freed. Smaller blocks stay in the heap: they are many (every small array and Python
object) and their waste is bounded; at 2,939 disks no particle array reaches it."""

REUSE_MMAP, REUSE_TRIM = 32 << 20, 64 << 20
"""The steps' thresholds: glibc's largest dynamic mmap threshold and its trim threshold then."""


def _libc(name: str, argtypes: tuple):
    """The C library's function ``name`` (returning int), or None where it has none."""
    try:
        fn = getattr(ctypes.CDLL(None), name)
    except (OSError, AttributeError):
        return None
    fn.argtypes, fn.restype = argtypes, ctypes.c_int
    return fn


def _mallopt(settings: tuple[tuple[int, int], ...]) -> bool:
    """Set glibc malloc parameters (process-wide; a fixed mmap threshold also turns off its
    growth). False where the C library has no ``mallopt`` or refuses one (not glibc)."""
    mallopt = _libc("mallopt", (ctypes.c_int, ctypes.c_int))
    return mallopt is not None and all([mallopt(p, v) == 1 for p, v in settings])


def unmap_freed_arrays() -> bool:
    """Blocks of MMAP_THRESHOLD bytes or more go back to the system when freed."""
    return _mallopt(((M_MMAP_THRESHOLD, MMAP_THRESHOLD),))


def reuse_freed_arrays() -> bool:
    """Blocks up to REUSE_MMAP bytes stay in the heap for reuse when freed."""
    return _mallopt(((M_MMAP_THRESHOLD, REUSE_MMAP), (M_TRIM_THRESHOLD, REUSE_TRIM)))


def give_back_free_heap() -> bool:
    """The heap's free blocks returned to the system (glibc's ``malloc_trim``)."""
    trim = _libc("malloc_trim", (ctypes.c_size_t,))
    return trim is not None and trim(0) == 1


@contextmanager
def unmapped():
    """Blocks freed inside go back to the system, then the steps' reuse again. For an exchange:
    its arrays (migrants, merged histories, new layouts) have sizes no build makes, so the heap
    would grow by them once more instead of reusing. The builds' blocks the heap kept are
    given back first: otherwise the exchange's own arrays come on top of them, and that sum
    was a 1M-disk run's peak (the next build maps them again)."""
    give_back_free_heap()
    unmap_freed_arrays()
    try:
        yield
    finally:
        reuse_freed_arrays()


def prepare_memory(scene: Scene, comm=None) -> None:
    """Before a scene's arrays exist: freed arrays given back (``unmap_freed_arrays``), and a
    SceneError when the scene needs more memory per rank than this node has available per
    rank (collective: every rank decides alike, from the smallest share of any node)."""
    unmap_freed_arrays()
    available = available_bytes()
    share = smallest_node_share(comm, float("inf") if available is None else available)
    # this process's interpreter and libraries are already resident: not new memory
    resident = peak_bytes()
    need = needed_bytes(scene)
    if need - min(resident, BASE_BYTES) > share:
        ranks = size_of(comm)
        raise SceneError(
            f"this run needs about {size_text(need)} per rank ({need_text(scene)}); only "
            f"{size_text(share)} per rank is available ({ranks} rank(s)): "
            + ("use fewer particles or a machine with more memory" if averaging_bytes(scene)
               < need / 2 else "average over fewer samples (a larger [averaging] "
               "sample_interval, a shorter window) or fewer rings (a larger ring_width)"))


def need_text(scene: Scene) -> str:
    """What ``needed_bytes`` is made of, in words."""
    text = (f"{particle_count(scene)} particles with the wall disks at ~{BYTES_PER_PARTICLE} "
            f"bytes each: every rank places the whole cell")
    samples, rings = averaging_shape(scene)
    if samples:
        text += (f"; {size_text(averaging_bytes(scene))} for the averaging's {samples} samples "
                 f"of {rings} rings, which every rank keeps")
    return text


def peak_bytes() -> float:
    """This process's peak resident memory so far (bytes)."""
    return 1024.0 * resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def size_text(n: float) -> str:
    for unit, scale in (("TiB", 2.0**40), ("GiB", 2.0**30), ("MiB", 2.0**20)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n / 2.0**20:.2g} MiB"

"""Files written whole or not at all: through ``NAME.tmp``, renamed when complete, after a
check that the disk and the process's file-size limit leave room for them.

Stage: output. h5py writing into a full disk, or past ``ulimit -f``, floods the terminal with
errors from its deallocators and can crash the interpreter (seen: exit 139 and 11), so the
room is checked before h5py touches the file, and a failed write's OSError names the file
(h5py's errors name none)."""

from __future__ import annotations

import errno
import os
import resource
import shutil
from contextlib import contextmanager
from pathlib import Path

OVERHEAD = 2**16  # bytes of HDF5 metadata beyond the arrays, generously


def check_room(path: Path, size: int) -> None:
    """OSError (EFBIG or ENOSPC, naming ``path``) if a file of about ``size`` bytes cannot be
    written there."""
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    if limit != resource.RLIM_INFINITY and size > limit:
        raise OSError(errno.EFBIG, f"File too large (~{size / 1e6:.2f} MB; the file-size limit "
                                   f"is {limit / 1e6:.2f} MB)", str(path))
    if shutil.disk_usage(path.parent).free < size:
        raise OSError(errno.ENOSPC, f"No space left on device (~{size / 1e6:.2f} MB needed)",
                      str(path))


def size_of(*tables) -> int:
    """A generous size (bytes) of a file holding the arrays of the given dicts."""
    data = sum(getattr(v, "nbytes", 0) for t in tables if t for v in t.values())
    return int(1.5 * data) + OVERHEAD


@contextmanager
def writing(path: Path, size: int = 0):
    """Yield the temporary path to write ``path`` through; rename it at the end. ``size``:
    the expected size (bytes), checked first (check_room). A failed write removes the
    temporary file and its OSError names ``path``."""
    if size:
        check_room(path, size)
    tmp = path.with_name(path.name + ".tmp")
    try:
        yield tmp
    except OSError as e:
        tmp.unlink(missing_ok=True)
        raise OSError(e.errno, e.strerror or str(e), str(path)) from e
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)

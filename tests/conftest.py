"""How the suite is spread over pytest-xdist's workers (``-n 2 --dist loadgroup`` in
pyproject.toml). Compiling a scene's kernels dominates a cold run, so each test file stays on
one worker (its tests mostly share the compiled variants). Every file that starts MPI jobs is
in one group "mpi": at most one MPI job runs at a time, beside serial tests, so two 2-rank jobs
never share the 2 cores of a small machine."""

from pathlib import Path

import pytest

MPI_MARKERS = ("mpi_helpers", "from regression import")


def _group(path: Path) -> str:
    text = path.read_text(encoding="utf-8")
    return "mpi" if any(m in text for m in MPI_MARKERS) else path.stem


def pytest_collection_modifyitems(config, items):
    groups: dict[Path, str] = {}
    for item in items:
        path = Path(str(item.fspath))
        if path not in groups:
            groups[path] = _group(path)
        item.add_marker(pytest.mark.xdist_group(groups[path]))

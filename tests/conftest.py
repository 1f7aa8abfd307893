"""How the suite is spread over pytest-xdist's workers (``-n 2`` in pyproject.toml). Compiling
a scene's kernels dominates a cold run, so each test file stays on one worker (its tests mostly
share the compiled variants), and every file that starts MPI jobs joins one group: at most one
MPI job runs at a time, beside serial tests, so two 2-rank jobs never share the 2 cores of a
small machine. (xdist's own ``loadgroup`` marks have no effect with pytest 9: its node-id
suffix is ignored, hence a scheduler here.)"""

from pathlib import Path

MPI_MARKERS = ("mpi_helpers", "from regression import")
ROOT = Path(__file__).resolve().parents[1]

try:
    from xdist.scheduler import LoadScopeScheduling
except ImportError:  # run without xdist: nothing to schedule
    LoadScopeScheduling = None


if LoadScopeScheduling is not None:

    class FileOrMpiScheduling(LoadScopeScheduling):
        """Scope = the test file, or "mpi" for every file that starts MPI jobs."""

        def __init__(self, config, log=None):
            super().__init__(config, log)
            self._groups: dict[str, str] = {}

        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.split("::", 1)[0]
            if path not in self._groups:
                text = (ROOT / path).read_text(encoding="utf-8")
                self._groups[path] = "mpi" if any(m in text for m in MPI_MARKERS) else path
            return self._groups[path]

    def pytest_xdist_make_scheduler(config, log):
        return FileOrMpiScheduling(config, log)

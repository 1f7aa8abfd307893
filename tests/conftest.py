"""How the suite is spread over pytest-xdist's workers (``-n 2`` in pyproject.toml). Compiling
a scene's kernels dominates a cold run, so each test file stays on one worker (its tests mostly
share the compiled variants), and every file that starts MPI jobs joins one group: at most one
MPI job runs at a time, beside serial tests, so two 2-rank jobs never share the 2 cores of a
small machine. (xdist's own ``loadgroup`` marks have no effect with pytest 9: its node-id
suffix is ignored, hence a scheduler here.) Tests that are long on their own are marked
``long`` here (LONG), so that ``-m "not slow and not long"`` is a fast subset."""

from pathlib import Path

import pytest

MPI_MARKERS = ("mpi_helpers", "from regression import")
ROOT = Path(__file__).resolve().parents[1]

LONG = {
    # tests that compile a set of effects no other fast test uses, start MPI jobs or run long
    # simulations (over 15 s each in a full run on a busy 2-core machine); the fast subset,
    # python -m pytest -m "not slow and not long", leaves them out
    "test_violent_impact_stays_finite_and_loses_energy",
    "test_densest_packings_compress_boundedly_and_relax",
    "test_random_couette_cells_stay_finite_and_inside",
    "test_quick_accuracy_study_writes_every_section",
    "test_halfstep_integrator_converges_to_analytic",
    "test_wall_collision_restitution_infinite_mass_partner",
    "test_bottom_friction_decelerates_at_mu_b_g_then_rests_exactly",
    "test_elastic_dense_scene_conserves_energy_second_order",
    "test_compiled_force_loop_equals_sum_of_kernel_calls",
    "test_rolling_resistance_slows_a_rolling_disk_as_predicted",
    "test_sticking_contact_oscillates_as_the_damped_tangential_spring",
    "test_compressed_packing_is_stable",
    "test_eta_is_the_integral_of_the_tangential_velocity",
    "test_tracking_eta_leaves_the_trajectory_and_costs_a_history_only_where_read",
    "test_a_serial_run_loads_no_mpi",
    "test_plot_writes_every_figure",
    "test_manual_builds_strictly",
}


def pytest_collection_modifyitems(config, items):
    for item in items:
        text = item.path.read_text(encoding="utf-8")
        if item.originalname in LONG or any(m in text for m in MPI_MARKERS):
            item.add_marker(pytest.mark.long)

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

"""Remove each guard of the hard-case suite once and check that its test then fails.

    python tests/hard/mutations.py

Each mutation edits one source file (the guard removed or weakened) in a temporary copy of the
tree, runs the one test that must catch it there, and restores the file; the working tree is
never touched, so other tests may run meanwhile. A mutation of compiled code gets a
fresh numba cache by itself (pardem/core/jit.py keys the cache by the sources), so the whole check
takes long and runs as a slow-marked test (tests/hard/test_mutations.py), not in the default
run. It exits non-zero if a mutation survives or the list went stale.
"""

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HARD = "tests/hard/"
MUTATIONS = [  # (guard, file, its text, the text without it, the test that must catch it)
    ("Coulomb cap at |f_t| = mu|f_n| = 0 (strict >)", "pardem/contact/laws.py",
     "cl_sliding = cl_ft2 > cl_fmax * cl_fmax", "cl_sliding = cl_ft2 >= cl_fmax * cl_fmax",
     HARD + "test_contacts_hard.py::"
     "test_contact_law_with_zero_tangential_velocity_and_zero_spring"),
    ("bottom friction at rest (speed <= dv)", "pardem/core/integrate.py",
     "            rest = speed <= dv", "            rest = False",
     HARD + "test_contacts_hard.py::"
     "test_disk_at_rest_with_bottom_friction_stays_exactly_at_rest"),
    ("ring speed refusal", "pardem/core/timestep.py",
     "    g = scene.geometry\n    if g is None:\n        return\n    k_load = ",
     "    g = scene.geometry\n    if g is None or True:\n        return\n    k_load = ",
     HARD + "test_packings_hard.py::test_ring_too_fast_for_the_contact_law_is_refused"),
    ("watchdog: centre beyond the current ring line", "pardem/core/integrate.py",
     "        hi2, lo2 = r_hi * r_hi, prm.rings.r_in * prm.rings.r_in",
     "        hi2, lo2 = 1.0, prm.rings.r_in * prm.rings.r_in",
     HARD + "test_parallel_hard.py::"
     "test_watchdog_names_the_particle_and_keeps_the_last_checkpoint"),
    ("watchdog: NaN", "pardem/core/integrate.py",
     "        n_bad += 0 if lo2 <= r2 <= hi2 else 1  # also counts NaN",
     "        n_bad += 1 if r2 < lo2 or r2 > hi2 else 0  # NaN slips through",
     HARD + "test_parallel_hard.py::test_watchdog_on_two_ranks_stops_every_rank"),
    ("checkpoint content checks", "pardem/output/restart.py",
     "            _check_rows(path, key, rows, getattr(ps, key)[:k], idx)\n", "",
     HARD + "test_files_hard.py::test_corrupted_checkpoint_is_refused"),
    ("placement within the band", "pardem/input/placement.py",
     "room = np.maximum(np.minimum(0.5 * spacing - radius, band), 0.0) * 0.99",
     "room = np.maximum(0.5 * spacing - radius, 0.0) * 0.99",
     HARD + "test_random_scenes.py::test_initial_placement_never_overlaps"),
    ("ring weights never negative", "averaging/weights.py",
     "        outer = min(max(outer, below), 1.0)\n", "",
     HARD + "test_parallel_hard.py::test_ring_edges_in_the_averaging"),
    ("the last ring reached takes the rest of the weight", "averaging/weights.py",
     "        outer = 1.0 if k == k_hi else inside_share(",
     "        outer = 1.0 if k == n_rings - 1 else inside_share(",
     HARD + "test_parallel_hard.py::test_ring_edges_in_the_averaging"),
    ("block errors of all-NaN rings", "averaging/timeavg.py",
     "block_error(np.array([p[key] for p in per]))",
     "np.nanstd(np.array([p[key] for p in per]), axis=0, ddof=1)",
     HARD + "test_packings_hard.py::test_rings_without_contacts_are_nan_marked_not_a_crash"),
]

def main() -> int:
    stale = [f"{label}: its text is not (once) in {rel}" for label, rel, old, _, _ in MUTATIONS
             if (ROOT / rel).read_text().count(old) != 1]
    if stale:  # checked before any file is touched
        sys.exit("the source changed, update MUTATIONS:\n  " + "\n  ".join(stale))
    survivors = 0
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp)
        skip = shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc")
        for part in ("pardem", "averaging", "tests", "run_scripts", "docs"):
            shutil.copytree(ROOT / part, tree / part, ignore=skip)
        shutil.copy(ROOT / "pyproject.toml", tree)
        env = dict(os.environ, PYTHONPATH=str(tree))  # the copy shadows the installed pardem

        def pytest(*tests):
            return subprocess.run([sys.executable, "-m", "pytest", "-x", "-q", "-p",
                                   "no:cacheprovider", "-n", "0", *tests], cwd=tree, env=env,
                                  capture_output=True, text=True, timeout=1800)

        # a test that fails on the intact code would count every mutation as caught
        intact = pytest(*sorted({test for *_, test in MUTATIONS}))
        if intact.returncode != 0:
            print("the intact tree fails its own tests:\n" + intact.stdout[-3000:], flush=True)
            return len(MUTATIONS)
        for label, rel, old, new, test in MUTATIONS:
            path = tree / rel
            text = path.read_text()
            path.write_text(text.replace(old, new))
            try:
                proc = pytest(test)
            finally:
                path.write_text(text)
            # exit code 1: the test ran and failed (not a collection or usage error)
            caught = proc.returncode == 1 and " failed" in proc.stdout
            survivors += not caught
            print(f"{label:50s} -> {'caught' if caught else 'NOT CAUGHT'} by {test}", flush=True)
            if not caught:
                print("    " + (proc.stdout + proc.stderr)[-1500:].replace("\n", "\n    "))
    print(f"{len(MUTATIONS) - survivors} of {len(MUTATIONS)} caught in "
          f"{time.perf_counter() - start:.0f} s", flush=True)
    return survivors


if __name__ == "__main__":
    sys.exit(main())

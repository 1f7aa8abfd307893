"""Remove each guard of the hard-case suite once and check that its test then fails.

    python tests/hard/mutations.py

Each mutation edits one source file (the guard removed or weakened), runs the one test that
must catch it, and restores the file, whatever happens. Run by hand (minutes: each mutation
recompiles the kernels it touches); the outcome is recorded in tests/hard/README.md.
"""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MUTATIONS = [
    ("Coulomb cap at |f_t| = mu|f_n| = 0 (strict >)", "pardem/contact.py",
     "if ft2 > fmax * fmax:", "if ft2 >= fmax * fmax:",
     "tests/hard/test_contacts_hard.py::test_contact_law_with_zero_tangential_velocity_and_zero_spring"),
    ("bottom friction at rest (speed <= dv)", "pardem/stepper.py",
     "            if speed <= dv:\n                vx = 0.0\n                vy = 0.0\n            else:\n                c = 1.0 - dv / speed",
     "            if False:\n                vx = 0.0\n                vy = 0.0\n            else:\n                c = 1.0 - dv / speed",
     "tests/hard/test_contacts_hard.py::test_disk_at_rest_with_bottom_friction_stays_exactly_at_rest"),
    ("ring speed refusal", "pardem/timestep.py",
     "    g = scene.geometry\n    if g is None:\n        return\n    worst = ",
     "    g = scene.geometry\n    if g is None or True:\n        return\n    worst = ",
     "tests/hard/test_packings_hard.py::test_ring_too_fast_for_the_contact_law_is_refused"),
    ("watchdog: centre beyond the current ring line", "pardem/stepper.py",
     "        hi2, lo2 = r_hi * r_hi, prm.r_in * prm.r_in",
     "        hi2, lo2 = 1.0, prm.r_in * prm.r_in",
     "tests/hard/test_parallel_hard.py::test_watchdog_names_the_particle_and_keeps_the_last_checkpoint"),
    ("watchdog: NaN", "pardem/stepper.py",
     "        if not (lo2 <= r2 <= hi2):  # also catches NaN",
     "        if r2 < lo2 or r2 > hi2:  # NaN slips through",
     "tests/hard/test_parallel_hard.py::test_watchdog_on_two_ranks_stops_every_rank"),
    ("checkpoint content checks", "pardem/simulation.py",
     "        _check_restored(path, arrays, ps)\n", "",
     "tests/hard/test_files_hard.py::test_corrupted_checkpoint_is_refused"),
    ("placement within the band", "pardem/placement.py",
     "room = np.maximum(np.minimum(0.5 * spacing - radius, band), 0.0) * 0.99",
     "room = np.maximum(0.5 * spacing - radius, 0.0) * 0.99",
     "tests/hard/test_random_scenes.py::test_initial_placement_never_overlaps"),
    ("ring weights never negative", "averaging/weights.py",
     "        outer = min(max(outer, below), 1.0)\n", "",
     "tests/hard/test_parallel_hard.py::test_ring_edges_in_the_averaging"),
    ("the last ring reached takes the rest of the weight", "averaging/weights.py",
     "        outer = 1.0 if k == k_hi else inside_share(r0 + (k + 1) * dr, rho, a, kind)",
     "        outer = 1.0 if k == n_rings - 1 else inside_share(r0 + (k + 1) * dr, rho, a, kind)",
     "tests/hard/test_parallel_hard.py::test_ring_edges_in_the_averaging"),
    ("block errors of all-NaN rings", "averaging/rings.py",
     "                out[key + \"_err\"] = block_error(np.array([p[key] for p in per]))",
     "                out[key + \"_err\"] = np.nanstd(np.array([p[key] for p in per]), axis=0, ddof=1)",
     "tests/hard/test_packings_hard.py::test_rings_without_contacts_are_nan_marked_not_a_crash"),
]

def main() -> int:
    survivors = 0
    for label, rel, old, new, test in MUTATIONS:
        path = ROOT / rel
        text = path.read_text()
        assert text.count(old) == 1, f"{label}: the guard's text is no longer in {rel}"
        path.write_text(text.replace(old, new))
        try:
            proc = subprocess.run([sys.executable, "-m", "pytest", "-x", "-q", "-p",
                                   "no:cacheprovider", test], cwd=ROOT, capture_output=True,
                                  text=True, timeout=900)
        finally:
            path.write_text(text)
        caught = proc.returncode != 0
        survivors += not caught
        print(f"{label:50s} -> {'caught' if caught else 'NOT CAUGHT'} by {test}", flush=True)
    return survivors


if __name__ == "__main__":
    sys.exit(main())

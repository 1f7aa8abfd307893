"""The regression reference: digests of the state after fixed step counts of three scenes.

The scenes are frozen copies in ``tests/reference/`` (the shipped scenes may change; these must
not). ``digest`` hashes what a refactor must keep bit for bit, sorted by id: positions,
velocities, angles, spins, forces and torques of every particle, and the contact history
(the Cundall-Strack springs of disk-disk and disk-ring contacts, keyed by gid pair; the
paper's eta separately, since it is bookkeeping that no force reads).

``python tests/regression.py`` recomputes the reference on one rank and rewrites
``tests/reference/state_digests.json``: only for a change that is meant to change the
trajectories, and say so in the commit.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

REFERENCE = Path(__file__).parent / "reference"
DIGESTS = REFERENCE / "state_digests.json"
# scene file -> steps: Couette compression with every effect and eta (couette_quick), a small
# cell sheared fast (many migrations and exchanges under MPI), a frictionless free packing
CASES = {"couette_quick.toml": 3000, "fast_shear.toml": 6000, "free_frictionless.toml": 4000}
DYNAMICS = ("gid", "x", "v", "theta", "omega", "f", "tau")


def digest(state: dict[str, np.ndarray]) -> dict[str, str | None]:
    """``{"dynamics": hex, "eta": hex or None}`` of a gathered state (arrays as in a checkpoint:
    particles sorted by gid; pair_lo, pair_hi and the history (pair_hist, or pair_xi in the
    format before the contact slots) sorted by key; the history columns are the spring, then
    eta where tracked)."""
    h = hashlib.sha256()
    for key in DYNAMICS:
        h.update(np.ascontiguousarray(state[key]).tobytes())
    h.update(np.ascontiguousarray(state["pair_lo"], np.int64).tobytes())
    h.update(np.ascontiguousarray(state["pair_hi"], np.int64).tobytes())
    pair, wall = (np.asarray(state[k], float) for k in (
        ("pair_hist", "hist_wall") if "pair_hist" in state else ("pair_xi", "xi_wall")))
    for xi in (pair, wall):
        h.update(np.ascontiguousarray(xi[:, :2] if xi.size else xi).tobytes())
    eta = None
    if pair.ndim == 2 and pair.shape[1] == 4:
        e = hashlib.sha256(np.ascontiguousarray(pair[:, 2:]).tobytes())
        e.update(np.ascontiguousarray(wall[:, 2:]).tobytes())
        eta = e.hexdigest()
    return {"dynamics": h.hexdigest(), "eta": eta}


def expected() -> dict[str, dict]:
    return json.loads(DIGESTS.read_text())


def main() -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    from mpi_helpers import dump_state

    import tempfile

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, steps in CASES.items():
            state = dump_state(REFERENCE / name, steps, Path(tmp) / "s.npz", 1)
            out[name] = {"steps": steps, **digest(state)}
            print(name, out[name], flush=True)
    DIGESTS.write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

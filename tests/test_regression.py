"""The regression reference (tests/regression.py): the state after fixed step counts of three
frozen scenes equals, bit for bit, the digest stored from the code before the restructuring, on
1, 2 and 3 ranks (3 oversubscribe 2 cores: fine for correctness)."""

import pytest
from mpi_helpers import dump_state
from regression import CASES, REFERENCE, digest, expected


@pytest.mark.parametrize("ranks", [1, 2, 3])
@pytest.mark.parametrize("name", sorted(CASES))
def test_state_matches_the_stored_reference(tmp_path, name, ranks):
    ref = expected()[name]
    state = dump_state(REFERENCE / name, ref["steps"], tmp_path / "s.npz", ranks, timeout=600)
    got = digest(state)
    assert int(state["step"]) == ref["steps"]
    assert got["dynamics"] == ref["dynamics"], f"{name} on {ranks} ranks: trajectories differ"
    assert got["eta"] == ref["eta"], f"{name} on {ranks} ranks: eta differs"

"""The regression reference (tests/regression.py): the state after fixed step counts of three
frozen scenes equals, bit for bit, the digest stored from the code before the restructuring, on
1, 2 and 3 ranks (3 oversubscribe 2 cores: fine for correctness)."""

import pytest
from mpi_helpers import dump_state
from pardem.core.timing import END, PACK, REFRESH, STEPS, UNPACK
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


def test_a_restart_continues_to_the_stored_reference(tmp_path):
    """fast_shear checkpointed halfway on 1 rank and continued on 2: the stored digest of the
    uninterrupted run (the restart's part of the reference a refactor must keep)."""
    name, ref = "fast_shear.toml", expected()["fast_shear.toml"]
    half, ckpt = ref["steps"] // 2, tmp_path / "half.h5"
    dump_state(REFERENCE / name, half, tmp_path / "a.npz", 1, "--checkpoint-at", str(half),
               str(ckpt))
    state = dump_state(REFERENCE / name, ref["steps"], tmp_path / "b.npz", 2, "--restart",
                       str(ckpt))
    assert int(state["step"]) == ref["steps"]
    assert digest(state) == {"dynamics": ref["dynamics"], "eta": ref["eta"]}


def test_a_timed_run_keeps_the_reference_and_times_the_refresh_in_parts(tmp_path):
    """The step loop with its stage timers (``pardem run --timing``) on 2 ranks: the same
    digest, every step counted once per rank, and the refresh's parts within it."""
    name, ref = "fast_shear.toml", expected()["fast_shear.toml"]
    state = dump_state(REFERENCE / name, ref["steps"], tmp_path / "t.npz", 2, "--timing")
    assert digest(state) == {"dynamics": ref["dynamics"], "eta": ref["eta"]}
    for rank, row in enumerate(state["timing"]):
        t, w = row[:END], row[END:]  # Clock.deep, then Decomposition.wait
        assert t[STEPS] == ref["steps"], rank
        assert w[PACK] > 0.0 and w[UNPACK] > 0.0, rank
        assert w[0] + w[PACK] + w[UNPACK] <= t[REFRESH], rank

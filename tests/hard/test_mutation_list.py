"""The mutation check (``python tests/hard/mutations.py``, run by hand) stays usable: every guard
it removes is still in the source, once. Without this the list silently goes stale when a guard
is rewritten (it did once: two of the ten guards had been reworded)."""

import importlib.util
from pathlib import Path

HERE = Path(__file__).resolve().parent


def test_every_guard_of_the_mutation_check_is_still_in_the_source():
    spec = importlib.util.spec_from_file_location("mutations", HERE / "mutations.py")
    mutations = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mutations)
    assert len(mutations.MUTATIONS) == 10
    for label, rel, old, new, test in mutations.MUTATIONS:
        assert (mutations.ROOT / rel).read_text().count(old) == 1, f"{label}: guard not in {rel}"
        assert old != new, label
        path, name = test.split("::")
        assert f"def {name}(" in (mutations.ROOT / path).read_text(), f"{label}: no test {test}"

"""The manual: it builds without warnings, its input reference is the scene schema's, the tables
of its scaling page are rendered from the committed measurements, the README's test count is
pytest's, and the examples it points to are valid scenes."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "run_scripts" / "tools"), str(ROOT / "run_scripts" / "benchmarks")]

import readme_counts  # noqa: E402
import scaling_tables  # noqa: E402
from input_reference import PAGE, render  # noqa: E402

from pardem.check import describe  # noqa: E402
from pardem.input.scene_file import load_scene  # noqa: E402


def test_input_reference_is_generated_from_the_current_schema():
    assert PAGE.read_text() == render(), "run: python run_scripts/tools/input_reference.py"


def test_scaling_tables_are_generated_from_the_committed_results():
    for page in scaling_tables.PAGES:
        assert page.read_text(encoding="utf-8") == scaling_tables.render(page=page), \
            f"{page.name}: run python run_scripts/benchmarks/scaling_tables.py"


def test_the_scaling_page_is_a_design_page_without_commit_hashes():
    """At most 250 lines, and no word that reads as a commit hash (7-40 hex digits with a
    letter and a digit): the page describes the design and the measurements, git the history."""
    for page in (ROOT / "docs").glob("*.md"):
        words = re.findall(r"\b[0-9a-f]{7,40}\b", page.read_text(encoding="utf-8"))
        assert not [w for w in words if re.search("[a-f]", w) and re.search("[0-9]", w)], page
    assert len((ROOT / "docs" / "scaling.md").read_text(encoding="utf-8").splitlines()) <= 250


def test_readme_counts_the_tests_pytest_collects():
    """The README's "N of the M tests" against pytest's own collection (a subprocess)."""
    text = readme_counts.README.read_text(encoding="utf-8")
    assert readme_counts.render(text, readme_counts.collected()) == text, \
        "run: python run_scripts/tools/readme_counts.py"


def test_ci_runs_the_readme_test_command_verbatim():
    ci = (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert ci.endswith("python -m pytest") and f"\n{ci}\n" in (ROOT / "README.md").read_text()


def test_every_key_the_validator_accepts_is_in_the_input_reference():
    """schema._TABLES is what scene_from_dict checks against: a table added there but not to
    the generator would be accepted yet undocumented."""
    from pardem.input.schema import _TABLES

    text = PAGE.read_text()
    for table, keys in _TABLES.items():
        assert f"## `[{table}]`" in text or f"## `[[{table}]]`" in text, table
        for key in keys:
            assert f"| `{key}` |" in text, f"[{table}] {key}"


def test_manual_builds_strictly(tmp_path):
    mkdocs = Path(sys.executable).parent / "mkdocs"
    done = subprocess.run([str(mkdocs), "build", "--strict", "-q", "-d", str(tmp_path / "site")],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    paper = (tmp_path / "site" / "paper" / "index.html").read_text()
    assert "Where we agree" in paper  # the README's section, pulled in by docs/hooks.py
    assert (tmp_path / "site" / "paper" / "figures" / "fig_1_3_velocity.png").exists()


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "examples").glob("*.toml")))
def test_examples_are_valid_scenes(name):
    text = describe(load_scene(ROOT / "examples" / name))
    assert "steps to t =" in text

"""The README's count of the fast test subset ("N of the M tests"), from pytest's own
collection, so that it cannot go stale (``tests/test_manual.py`` checks it).

    python run_scripts/tools/readme_counts.py            # rewrites the count in README.md
    python run_scripts/tools/readme_counts.py --check    # exit 1 if the README's count is stale
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
FAST = "not slow and not long"
PHRASE = re.compile(r"\(\d+ of the \d+ tests:")


def collected() -> tuple[int, int]:
    """(tests in the fast subset, every test) as ``pytest --collect-only`` counts them: the
    marker expression replaces the default ``-m 'not slow'``, so the total includes slow."""
    done = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-n", "0",
                           "-m", FAST], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)
    found = re.search(r"^(\d+)/(\d+) tests collected", done.stdout, re.MULTILINE)
    if found is None:
        raise RuntimeError(f"pytest --collect-only gave no count:\n{done.stdout[-2000:]}"
                           f"{done.stderr[-2000:]}")
    return int(found[1]), int(found[2])


def render(text: str, counts: tuple[int, int]) -> str:
    """The README ``text`` with its fast-subset phrase saying ``counts``."""
    if len(PHRASE.findall(text)) != 1:
        raise ValueError(f"README.md: expected one phrase like '(N of the M tests:', "
                         f"found {len(PHRASE.findall(text))}")
    return PHRASE.sub(f"({counts[0]} of the {counts[1]} tests:", text)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if the count is stale")
    args = parser.parse_args()
    text = README.read_text(encoding="utf-8")
    new = render(text, collected())
    if args.check:
        if new != text:
            print(f"{README}: the fast-subset count is stale: run "
                  "python run_scripts/tools/readme_counts.py")
            return 1
        return 0
    README.write_text(new, encoding="utf-8")
    print(PHRASE.search(new)[0])
    return 0


if __name__ == "__main__":
    sys.exit(main())

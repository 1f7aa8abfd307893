"""Row tables gathered from the ranks (no MPI here)."""

from __future__ import annotations

import numpy as np

from ..core.state import join_rows


def sorted_rows(parts: list[dict[str, np.ndarray]], key: str) -> dict[str, np.ndarray]:
    """Row tables joined and sorted by ``key`` (a column, or [n,2] columns: lexicographic)."""
    joined = join_rows(parts)
    k = joined[key]
    order = np.lexsort(k.T[::-1]) if k.ndim == 2 else np.argsort(k, kind="stable")
    return {name: v[order] for name, v in joined.items()}

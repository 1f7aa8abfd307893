"""One rank: the decomposition's interface without MPI (nothing to migrate, no ghosts, no
messages; reductions are identities), and what both decompositions share."""

from __future__ import annotations

import numpy as np

from . import cut as ct
from .comm_rows import sorted_rows

History = tuple[np.ndarray, np.ndarray, np.ndarray]  # (gid_lo, gid_hi, rows) sorted by key


class SerialDecomposition:
    """The whole cell on one rank (see comm.Decomposition for the interface)."""

    parallel = False
    comm = None
    size = 1
    rank = 0
    halo = None  # the step loop is compiled without a ghost refresh

    def __init__(self, reach_width: float, margin: float = 0.0):
        self.margin = margin
        self.ghost_width = reach_width + margin
        self.cut = ct.single()
        self.wait = np.zeros(3)
        self.n_exchanges = self.n_migrated = self.n_rebalanced = 0
        self.n_windows = self.n_shared_exchanges = 0

    def max(self, value):
        return value

    def sum(self, value):
        return value

    def bcast(self, obj):
        return obj

    def bcast_call(self, fn, *args):
        return fn(*args)

    def first_message(self, message):
        return message

    def join(self, rows):
        return rows

    def gather_rows(self, rows: dict[str, np.ndarray], key: str = "gid"):
        return sorted_rows([rows], key)

    def place_cut(self, x_free: np.ndarray) -> None:
        pass

    def rebalance(self, x_owned: np.ndarray) -> None:
        pass

    def exchange_due(self, x_local: np.ndarray) -> bool:
        return False

    def ghost_values(self, own_values: np.ndarray) -> np.ndarray:
        return own_values[:0]

    def describe(self) -> str:
        return "1 rank"

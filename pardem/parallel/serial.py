"""One rank: the decomposition's interface without MPI (nothing to migrate, no ghosts, no
messages; reductions are identities), and what both decompositions share."""

from __future__ import annotations

import math

import numpy as np

from ..scene import SceneError
from . import sectors as sec
from .comm_rows import sorted_rows

History = tuple[np.ndarray, np.ndarray, np.ndarray]  # (gid_lo, gid_hi, rows) sorted by key
HIST_BINS = 4096  # angular bins of the particle histogram that places the sector cuts


def too_many_ranks(size: int, inner_radius: float, reach_width: float) -> None:
    """SceneError if ``size`` sectors would be narrower at the inner ring than the interaction
    reach (m; largest diameter + skin): a particle would need ghosts beyond its neighbours."""
    if size > 1 and inner_radius > 0.0:
        arc = 2.0 * math.pi * inner_radius / size
        if arc < reach_width:
            raise SceneError(
                f"{size} MPI ranks are too many for this cell: a sector would be "
                f"{arc * 1e3:.2f} mm wide at the inner ring, narrower than the interaction "
                f"reach {reach_width * 1e3:.2f} mm (largest diameter + skin); use at most "
                f"{int(2.0 * math.pi * inner_radius / reach_width)} ranks")


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
        self.sectors = sec.single()
        self.wait = np.zeros(1)
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

    def gather_rows(self, rows: dict[str, np.ndarray], key: str = "gid"):
        return sorted_rows([rows], key)

    def place_sectors(self, x_free: np.ndarray) -> None:
        pass

    def rebalance(self, x_owned: np.ndarray) -> None:
        pass

    def exchange_due(self, x_local: np.ndarray) -> bool:
        return False

    def exchanged(self, x_local: np.ndarray) -> None:
        pass

    def ghost_values(self, own_values: np.ndarray) -> np.ndarray:
        return own_values[:0]

    def describe(self) -> str:
        return "1 rank"

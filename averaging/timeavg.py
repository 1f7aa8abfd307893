"""Time averages of the ring sums: ``RingAverager`` collects one sample at a time (in situ from a
running Simulation, or from snapshots), averages the sums over the samples, then forms the
fields (fields.py: ratios after the average, SPEC §4) with standard errors from consecutive
blocks of samples.

Stage: averaging. ``sample(sim)`` is collective under MPI (one Allreduce, through the run's
decomposition); ``write(dir)`` writes rings.h5, rings.csv and rings.vtu (io.py).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .boundary import LOADS, summary, total_loads
from .fields import N_COLUMNS, group_fields
from .io import write_rings
from .sample import Sample, sample_simulation
from .sums import accumulate, reduce_sums
from .weights import WEIGHTINGS

ERROR_BLOCKS = 8  # consecutive blocks of samples for the standard errors


class RingAverager:
    """Rings of width ``dr`` (m) from ``r_in`` to ``r_out`` (m) about the axis; ``weighting``
    (weights.WEIGHTINGS), disk ``height`` (m), ``d_ref`` (m, the d~ of r~ = (r - R_i)/d~), k_n
    (N/m) and the inner ring's omega_in (rad/s) for the paper's normalisations; ``reducer``:
    the run's decomposition (its ``sum`` reduces over the ranks), None for one process."""

    def __init__(self, r_in: float, r_out: float, dr: float, weighting: str, height: float,
                 d_ref: float, k_n: float, omega_in: float, reducer=None):
        if weighting not in WEIGHTINGS:
            raise ValueError(f"weighting {weighting!r}: allowed are {sorted(WEIGHTINGS)}")
        self.r_in, self.dr, self.height, self.d_ref = r_in, dr, height, d_ref
        self.n_rings = max(int(math.ceil((r_out - r_in) / dr - 1e-9)), 1)
        self.kind = WEIGHTINGS[weighting]
        self.weighting = weighting
        self.reducer = reducer
        self.k_n, self.omega_in = k_n, omega_in
        self.samples: list[np.ndarray] = []
        self.times: list[float] = []
        self.loads: list[np.ndarray] = []  # per sample: boundary.LOADS (N m, N)

    def sample(self, sim) -> None:
        """Add the ring sums of the simulation's current state (collective under MPI)."""
        self.add(sample_simulation(sim), sim.time)

    def add(self, s: Sample, time: float) -> None:
        """Add one sample (this rank's particles; the totals are reduced over ranks)."""
        arguments = self.sum_arguments(s)
        accumulate(*arguments)
        local = arguments[-1]
        sums, _ = reduce_sums(local, np.zeros(0), self.reducer)
        rows = s.wall_rows if self.reducer is None else self.reducer.join(s.wall_rows)
        self.samples.append(sums)
        self.loads.append(total_loads(rows))
        self.times.append(time)

    def sum_arguments(self, s: Sample) -> tuple:
        """``sums.accumulate``'s arguments for sample ``s``: its particles and contacts, the
        rings, and zeroed ring sums [n_rings, N_COLUMNS] (this rank's, to be reduced)."""
        return (s.particles, s.contacts, (self.height, self.r_in, self.dr, self.kind),
                np.zeros((self.n_rings, N_COLUMNS)))

    @property
    def ring_centres(self) -> np.ndarray:
        return self.r_in + (np.arange(self.n_rings) + 0.5) * self.dr

    def field_arguments(self) -> tuple:
        """``fields.derived``'s arguments after the sums: ring centres r (m), dr (m), h (m),
        r_tilde, k'_n = k_n/h (N/m^2) and the wall speed Omega R_i (m/s)."""
        r = self.ring_centres
        return (r, self.dr, self.height, (r - self.r_in) / self.d_ref, self.k_n / self.height,
                self.omega_in * self.r_in)

    def blocks(self) -> list[np.ndarray]:
        """The consecutive blocks of samples (indices) the standard errors come from."""
        return np.array_split(np.arange(len(self.samples)), min(ERROR_BLOCKS, len(self.samples)))

    def fields(self) -> dict[str, np.ndarray]:
        """Time-averaged fields and their standard errors (key + "_err"). Errors come from
        block averages: the samples are cut into up to 8 consecutive blocks, each block's
        fields are formed from its averaged sums, and err = std(blocks) / sqrt(n_blocks).
        Consecutive samples are correlated, so the spread of single samples would understate
        the error; blocks longer than the correlation time do not."""
        return self.fields_and_blocks()[0]

    def fields_and_blocks(self) -> tuple[dict[str, np.ndarray], list[dict[str, np.ndarray]]]:
        """``fields()`` and the fields of each block (``blocks``) its errors come from."""
        if not self.samples:
            raise ValueError("no samples taken")
        stack, loads = np.array(self.samples), self.load_table()
        args = self.field_arguments()
        mean = group_fields(stack, loads, [np.arange(len(stack))], args)[0]
        out = {"r": args[0], "r_tilde": args[3]}
        per = group_fields(stack, loads, self.blocks(), args)
        for key, value in mean.items():
            out[key] = value
            if len(per) > 1:
                out[key + "_err"] = block_error(np.array([p[key] for p in per]))
        return out, per

    @property
    def torques(self) -> list[float]:
        """The inner ring's torque on the particles (N m) of every sample."""
        return [float(loads[0]) for loads in self.loads]

    def load_table(self) -> np.ndarray:
        """The ring loads of every sample [samples, len(boundary.LOADS)]."""
        return np.array(self.loads, float).reshape(len(self.loads), len(LOADS))

    def summary(self, r_out: float) -> str:
        """The time-averaged ring loads and their torque balance in one line (outer ring at
        ``r_out`` m)."""
        mean = dict(zip(LOADS, self.load_table().mean(axis=0)))
        return summary(mean, self.r_in, r_out, self.height, len(self.loads))

    def write(self, out_dir: str | Path) -> None:
        """rings.h5 (fields, errors, raw sums per sample), rings.csv and rings.vtu; atomic."""
        write_rings(Path(out_dir), self)


def block_error(blocks: np.ndarray) -> np.ndarray:
    """Standard error of the mean from block values [n_blocks, ...]: std (ddof 1) over the
    finite blocks / sqrt(their number); NaN where fewer than two are finite (a ring that is
    NaN in every block, e.g. without contacts)."""
    ok = np.isfinite(blocks)
    n = ok.sum(axis=0)
    filled = np.where(ok, blocks, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = filled.sum(axis=0) / n
        var = np.where(ok, (filled - mean) ** 2, 0.0).sum(axis=0) / (n - 1)
        return np.where(n >= 2, np.sqrt(var) / np.sqrt(n), np.nan)

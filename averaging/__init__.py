"""Micro-to-macro averaging of pardem runs: ring sums in the local polar frame, time averages,
continuum fields (SPEC §4).

Modules: weights.py (share of a disk in each ring: ``slice``, ``exact``, ``centre``,
``gaussian``), collect.py (one sample's particles and contacts, seen from each particle),
sums.py (the additive ring sums and their single Allreduce), rings.py (sampling, derived
fields, rings.h5/rings.csv, read_rings).
"""

from .rings import RingAverager, read_rings

__all__ = ["RingAverager", "read_rings"]

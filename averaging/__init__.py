"""Micro-to-macro averaging of pardem runs (SPEC §4), in situ or from snapshots.

Three independent choices, as in MercuryCG: the coordinates (rings about the cell's axis, every
quantity in the local polar frame), the weight of a disk in a ring (weights.py: ``slice``,
``exact``, ``centre``, ``gaussian``) and the fields (fields.py: the additive sums and the
fields derived from them, each defined once). The data flow of one sample: sample.py (the
particles and their contacts, seen from each particle) -> sums.py (the ring sums; one
Allreduce under MPI) -> timeavg.py (time averages, block errors; fields after averaging) ->
io.py (rings.h5, rings.csv, rings.vtu); tables.py reads them as xarray and pandas
tables. offline.py averages a run's snapshots with the same
code; report.py and plots.py compare with the paper.
"""

from .io import read_rings
from .tables import ring_dataset, ring_frame
from .timeavg import RingAverager

__all__ = ["RingAverager", "read_rings", "ring_dataset", "ring_frame"]

"""The ``[warnings]`` table: when a run warns that its input or its state looks physically
suspicious, and how each warning is silenced. The warnings themselves: ``output/warnings.py``
(the run's), ``input/sanity.py`` (the scene's); docs/warnings.md lists them.

Stage: input. Not physics: the table is left out of a scene's fingerprint, so a restart may
change it.
"""

from __future__ import annotations

from dataclasses import dataclass

from .values import key


@dataclass(frozen=True)
class WarningsCfg:
    """``[warnings]`` (optional; a warning never stops a run): overlap (the largest overlap,
    as a fraction of the smaller free diameter in the contact, above which a run warns, once
    in the compression and once after it; default 0.05; at 0.25 the run stops anyway),
    mass_ratio (how far, as a factor, the 2D densities m / (pi a^2) that the [[species]]
    masses imply may lie apart before the run warns; default 3), oversubscribe (false: warn
    when a node runs more ranks than it has cores for them; true: that is intended, e.g. a
    correctness test, no warning). ``false`` switches overlap or mass_ratio off."""

    overlap: float | bool = key(0.05, "", ">0 <=0.25")
    mass_ratio: float | bool = key(3.0, "", ">1")
    oversubscribe: bool = key(False)

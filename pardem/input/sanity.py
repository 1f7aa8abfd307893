"""What a valid scene may still get wrong physically, said before it runs: warnings, not
errors (``[warnings]``, warnings_table.py, sets or silences each). The run's own warnings,
on its state, are in ``output/warnings.py``; docs/warnings.md lists them all.

Stage: input.
"""

from __future__ import annotations

import math

from .scene import Scene, Species


def areal_density(s: Species, height: float) -> float:
    """The 2D density m / (pi a^2) (kg/m^2) that a species' mass implies: the material's
    density times the disk height ``height`` (m), the same for every disk of one material
    (a size distribution's disks have their masses from its density)."""
    if s.distributed:
        return s.density * height
    return s.mass / (math.pi * (s.diameter / 2) ** 2)


def _species_text(s: Species, height: float) -> str:
    size = (f"mass {s.mass:.4g} kg, diameter {s.diameter * 1e3:.4g} mm" if not s.distributed
            else f"density {s.density:.4g} kg/m^3, {s.diameter_distribution} diameters")
    return f"{s.name!r} ({size}: {areal_density(s, height):.4g} kg/m^2)"


def density_warning(scene: Scene) -> str | None:
    """Why the [[species]] masses do not look like disks of one material, or None: the
    densest and the lightest species' 2D densities lie more than [warnings] mass_ratio
    apart. Species without disks do not count; free scenes give masses per particle and are
    not checked."""
    limit = scene.warnings.mass_ratio
    present = [s for s in scene.species if s.count]
    if limit is False or len(present) < 2:
        return None
    h = scene.contact.height

    def rho(s: Species) -> float:
        return areal_density(s, h)

    lo, hi = min(present, key=rho), max(present, key=rho)
    ratio = rho(hi) / rho(lo)
    if ratio <= limit:
        return None
    others = [s for s in present if s is not lo and s is not hi]
    rest = ("; the others: " + ", ".join(_species_text(s, h) for s in others)) if others else ""
    return (f"[[species]] masses imply 2D densities m / (pi a^2) {ratio:.3g} x apart: "
            f"{_species_text(hi, h)} against {_species_text(lo, h)}{rest}. Disks of one material "
            "share one density (m = rho pi a^2 h): is a mass off by a factor (g for kg, a "
            "radius for a diameter)? Contact times, the time step and the flow follow the "
            f"masses as given. ([warnings] mass_ratio = {limit:g} sets how far apart they may "
            "be; false silences this)")

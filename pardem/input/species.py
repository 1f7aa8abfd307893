"""The ``[[species]]`` of a couette scene: disks of one diameter, or of a continuous size
distribution (uniform or log-normal in diameter), and the disks each species stands for.

Stage: input. ``check_species`` validates one table (schema.py calls it); ``species_disks``
gives every species' disks, diameters and masses, in the order placement.py hands them out.
A distribution's diameters are drawn from a generator seeded by the scene's ``[scene] seed``
and the species' index alone, so every rank, every run and every restart of a scene gets the
same disks; the time step, the checks and the averaging's defaults read the drawn disks, so
their bounds hold for the distribution's extreme disks (the lightest, the smallest, the
largest).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .errors import SceneError
from .values import fail, key

DISTRIBUTIONS = ("fixed", "uniform", "lognormal")
SHAPE_KEYS = ("diameter_min", "diameter_max", "diameter_median", "diameter_sigma")
"""The keys of the distributions' shapes; ``fixed`` takes none of them."""
NEEDS = {"fixed": (), "uniform": ("diameter_min", "diameter_max"),
         "lognormal": ("diameter_median", "diameter_sigma")}
ALLOWS = {"fixed": (), "uniform": NEEDS["uniform"], "lognormal": SHAPE_KEYS}
SMALLEST_WINDOW = 0.01
"""A truncated log-normal's [diameter_min, diameter_max] must hold at least this probability of
the untruncated one: the draws reject what falls outside."""


@dataclass(frozen=True)
class Species:
    """``[[species]]`` (couette only): name (unique), diameter (m), mass (kg) or density
    (kg/m^3 of the disks' material: mass = density pi (d/2)^2 h, h the [contact] height),
    count (>= 0); or, with ``[geometry] volume_fraction``, ``share`` (> 0, the species' part
    of the disks by number, in any unit: 2545 and 394 as well as 0.866 and 0.134) instead of
    ``count``. Instead of one diameter, a continuous size distribution
    (``diameter_distribution``, default "fixed": every disk has ``diameter``): "uniform",
    diameters uniform in [diameter_min, diameter_max); "lognormal", ln d normal with median
    ``diameter_median`` (m) and standard deviation ``diameter_sigma`` (of ln d), optionally
    truncated to [diameter_min, diameter_max] (either or both; the window must hold at least
    1 % of the untruncated distribution). A distribution takes ``density``, not ``mass``: each
    disk's mass follows from its diameter. The diameters are drawn from the [scene] seed and
    the species' place in the list, the same on any rank count and in every run; with
    volume_fraction the counts come from the distribution's mean disk area."""

    name: str = key()
    diameter: float | None = key(None, unit="m", rule=">0")
    mass: float | None = key(None, unit="kg", rule=">0")
    density: float | None = key(None, unit="kg/m^3", rule=">0")
    count: int | None = key(None, rule=">=0")
    share: float | None = key(None, rule=">0")
    diameter_distribution: str = key("fixed", rule="|".join(DISTRIBUTIONS))
    diameter_min: float | None = key(None, unit="m", rule=">0")
    diameter_max: float | None = key(None, unit="m", rule=">0")
    diameter_median: float | None = key(None, unit="m", rule=">0")
    diameter_sigma: float | None = key(None, rule=">0")

    @property
    def distributed(self) -> bool:
        """Whether the disks' diameters come from a distribution (not one ``diameter``)."""
        return self.diameter_distribution != "fixed"

    def mean_area(self) -> float:
        """The expected area pi d^2/4 (m^2) of one disk."""
        if not self.distributed:
            return math.pi * self.diameter**2 / 4
        if self.diameter_distribution == "uniform":
            a, b = self.diameter_min, self.diameter_max
            return math.pi / 4 * (a * a + a * b + b * b) / 3
        # E[d^2] of a log-normal: median^2 exp(2 sigma^2); truncated, the window's weight under
        # the density shifted by 2 sigma (d^2 f(d) is log-normal again), over the window's
        mu, s = math.log(self.diameter_median), self.diameter_sigma
        lo, hi = _window(self)
        shifted = _phi(hi - 2 * s) - _phi(lo - 2 * s)
        return math.pi / 4 * math.exp(2 * mu + 2 * s * s) * shifted / (_phi(hi) - _phi(lo))


def _phi(x: float) -> float:
    """The standard normal distribution function."""
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


def _window(s: Species) -> tuple[float, float]:
    """A log-normal's truncation in standard units (ln d - ln median)/sigma: -inf, inf if none."""
    def z(d: float | None, none: float) -> float:
        return none if d is None else (math.log(d) - math.log(s.diameter_median)) / s.diameter_sigma
    return z(s.diameter_min, -math.inf), z(s.diameter_max, math.inf)


def check_species(s: Species, i: int, height: float) -> Species:
    """One [[species]] table's keys together (each key's own checks: schema._parse): one
    diameter or a distribution's complete shape, a mass or a density; the mass of a fixed
    diameter from its density and the disks' height ``height`` (m)."""
    label = f"[[species]] #{i}"
    kind = s.diameter_distribution
    if not s.distributed and s.diameter is None:
        raise SceneError(f"{label} diameter: missing (give diameter in m, or a "
                         f"diameter_distribution: {', '.join(map(repr, DISTRIBUTIONS[1:]))})")
    if s.distributed and s.diameter is not None:
        raise fail(label, "diameter", s.diameter, f"not with diameter_distribution = {kind!r} "
                   f"(its disks' diameters come from {', '.join(NEEDS[kind])})", "m")
    for k in SHAPE_KEYS:
        if getattr(s, k) is not None and k not in ALLOWS[kind]:
            raise fail(label, k, getattr(s, k), f"not with diameter_distribution = {kind!r}; "
                       f"it takes {', '.join(ALLOWS[kind]) or 'diameter alone'}")
    for k in NEEDS[kind]:
        if getattr(s, k) is None:
            raise SceneError(f"{label} {k}: missing (required with diameter_distribution = "
                             f"{kind!r}, which needs {' and '.join(NEEDS[kind])})")
    lo, hi = s.diameter_min, s.diameter_max
    if lo is not None and hi is not None and not hi > lo:
        raise fail(label, "diameter_max", hi, f"must be > diameter_min = {lo!r}", "m")
    if kind == "lognormal":
        z_lo, z_hi = _window(s)
        if _phi(z_hi) - _phi(z_lo) < SMALLEST_WINDOW:
            which = "diameter_min" if z_lo > 0 else "diameter_max"
            raise fail(label, which, getattr(s, which), f"the window [{lo or 0:g}, {hi or math.inf:g}] m holds "
                       f"{_phi(z_hi) - _phi(z_lo):.3g} of the log-normal of median "
                       f"{s.diameter_median!r} m and sigma {s.diameter_sigma!r}; at least "
                       f"{SMALLEST_WINDOW:g} is needed", "m")
    if s.distributed and s.mass is not None:
        raise fail(label, "mass", s.mass, f"not with diameter_distribution = {kind!r}: each "
                   "disk's mass follows from its diameter; give density (kg/m^3, mass = "
                   "density pi (d/2)^2 h, h the [contact] height)", "kg")
    if s.mass is not None and s.density is not None:
        raise fail(label, "density", s.density, "mass is given too; give one of them (mass = "
                   "density pi (d/2)^2 h, h the [contact] height)", "kg/m^3")
    if s.mass is None and s.density is None:
        raise SceneError(f"{label} mass: missing (give mass in kg, or density in kg/m^3 of the "
                         "disks' material)" if not s.distributed else f"{label} density: "
                         "missing (required with a diameter_distribution, in kg/m^3)")
    if s.mass is not None or s.distributed:
        return s
    return dataclasses.replace(s, mass=disk_mass(s.density, s.diameter, height))


def disk_mass(density, diameter, height: float):
    """The mass (kg) of a disk of ``density`` (kg/m^3), ``diameter`` (m, or an array of them)
    and ``height`` (m): density pi (d/2)^2 h, the one expression every caller uses, so that a
    mass given as a density is the same bits wherever it is formed."""
    return density * math.pi * (diameter / 2) ** 2 * height


def species_disks(scene) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """(diameters m, masses kg) of each species' ``count`` disks of a couette scene, read-only
    (the same arrays for the same scene: cached)."""
    return tuple(disks_of(s, i, scene.info.seed, scene.contact.height)
                 for i, s in enumerate(scene.species))


def representative_disks(scene) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """species_disks as far as the scales need them: a drawn species' every disk, a fixed
    species' first two (they are all alike), so that the checks of a scene of 10^9 disks run
    before anything of its size is allocated (core/memory.py refuses it first)."""
    return tuple((d, m) if s.distributed else (d[:2], m[:2])
                 for s, (d, m) in zip(scene.species, species_disks(scene)))


def all_disks(scene) -> tuple[np.ndarray, np.ndarray]:
    """(diameters, masses) of the free disks of a couette scene that bound its scales (the
    smallest diameter, the two lightest disks), species after species: representative_disks."""
    parts = representative_disks(scene)
    return (np.concatenate([d for d, _ in parts]), np.concatenate([m for _, m in parts]))


def free_area(species: tuple[Species, ...], seed: int, height: float) -> float:
    """The area (m^2) of all free disks of these species (with their counts)."""
    return sum(s.count * math.pi * s.diameter**2 / 4 if not s.distributed else
               float(np.sum(math.pi * disks_of(s, i, seed, height)[0] ** 2 / 4))
               for i, s in enumerate(species))


@lru_cache(maxsize=32)
def disks_of(s: Species, index: int, seed: int, height: float) -> tuple[np.ndarray, np.ndarray]:
    n = s.count or 0
    if not s.distributed:  # views of one value: no memory however many disks
        d, m = (np.broadcast_to(np.float64(x), (n,)) for x in (s.diameter, s.mass))
    else:
        d = draw_diameters(s, n, np.random.default_rng(np.random.SeedSequence(
            seed, spawn_key=(index,))))
        m = disk_mass(s.density, d, height)
    for a in (d, m):
        a.setflags(write=False)
    return d, m


def draw_diameters(s: Species, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` diameters (m) of a distribution species drawn with ``rng`` (a truncated
    log-normal rejects the draws outside its window)."""
    if s.diameter_distribution == "uniform":
        return rng.uniform(s.diameter_min, s.diameter_max, n)
    mu, sigma = math.log(s.diameter_median), s.diameter_sigma
    lo, hi = s.diameter_min or 0.0, s.diameter_max or math.inf
    z_lo, z_hi = _window(s)
    kept = _phi(z_hi) - _phi(z_lo)
    out: list[np.ndarray] = []
    got = 0
    while got < n:
        x = rng.lognormal(mu, sigma, max(64, int(1.2 * (n - got) / kept) + 16))
        x = x[(x >= lo) & (x <= hi)][:n - got]
        out.append(x)
        got += x.size
    return np.concatenate(out) if out else np.zeros(0)

"""Scene description: the validated input of a pardem run.

Stage: input. A ``Scene`` is made of frozen, validated dataclasses (every key: docs/input.md,
generated from here); nothing downstream re-checks them.
The checks are in ``schema.py`` (``scene_from_dict``; free particles in ``particles.py``);
every problem raises ``SceneError`` naming the offending ``[table] key``. Files:
``scene_file.py``. Units are SI throughout: m, kg, s, rad, N.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..contact.keys import foreign_keys
from ..contact.normal import LAWS
from .errors import SceneError  # noqa: F401  (importers of the scene types read it here)
from .species import SHAPE_KEYS, Species, all_disks
from .values import Columns, key
from .warnings_table import WarningsCfg

if TYPE_CHECKING:
    from ..boundaries.wall_file import WallDisks


@dataclass(frozen=True)
class SceneInfo:
    """``[scene]``: kind ("couette" | "free"), name (default: file stem, else "scene"),
    seed (int >= 0, default 1; placement randomness is a function of seed and particle id)."""

    kind: str = key(rule="couette|free")
    name: str = key(None)
    seed: int = key(1, rule=">=0")


@dataclass(frozen=True)
class Geometry:
    """``[geometry]`` (couette only): inner_radius (m, 0.1035), outer_radius (m, final, 0.2525),
    outer_start_radius (m, at t = 0, 0.33), compression_time (s, 2.0), omega_inner (rad/s,
    counter-clockwise positive, 0.1), wall_particle_diameter (m, 2.5e-3),
    wall_particle_spacing (m, centre to centre along a ring, 7.0e-3).

    The wall layout of each ring (prefix ``inner_`` or ``outer_``): ``*_wall_count`` (glued
    disks on that ring, 0 = a smooth ring; "auto": round(2 pi R / wall_particle_spacing), at
    least 1), ``*_wall_diameter`` (m; "auto": wall_particle_diameter), ``*_flat_surface``
    (true: the flat ring surface behind the disks is a contact surface too). Disks may
    overlap. The outer ring's disks sit on its final radius's spacing and move with it.

    ``volume_fraction`` ("auto": the species' counts decide): fill the cell to this
    global volume fraction (free disks plus half of each wall disk, over pi (R_o^2 - R_i^2),
    the paper's v-bar); the species then give ``share`` instead of ``count``, and the counts
    are the nearest integers to share / sum(shares) x the number of disks that reach it. The
    resolved scene (``pardem check``, DIR/scene.toml) holds the counts. Given or from the
    counts, the fraction may not exceed pi / (2 sqrt 3) = 0.9069 (the hexagonal packing) for
    disks of one diameter, nor 1 for several."""

    inner_radius: float = key(0.1035, "m", ">0")
    outer_radius: float = key(0.2525, "m")
    outer_start_radius: float = key(0.33, "m")
    compression_time: float = key(2.0, "s", ">=0")
    omega_inner: float = key(0.1, "rad/s")
    wall_particle_diameter: float = key(2.5e-3, "m", ">0")
    wall_particle_spacing: float = key(7.0e-3, "m", ">0")
    inner_wall_count: int | None = key(None, rule=">=0")
    outer_wall_count: int | None = key(None, rule=">=0")
    inner_wall_diameter: float | None = key(None, "m", ">0")
    outer_wall_diameter: float | None = key(None, "m", ">0")
    inner_flat_surface: bool = key(True)
    outer_flat_surface: bool = key(True)
    volume_fraction: float | None = key(None, "", ">0")


_PUNITS = {"x": "m", "y": "m", "vx": "m/s", "vy": "m/s", "omega": "rad/s", "diameter": "m",
           "mass": "kg", "species": ""}
_PCOLS = tuple(_PUNITS)
MAX_SPECIES = 100  # a particle's species is one byte, beside the two rings' numbers


@dataclass(frozen=True, eq=False)
class FreeParticles(Columns):
    """Free-scene particles, row i = particle id i: read-only float64 arrays x, y (m, required),
    vx, vy (m/s, default 0), omega (rad/s, default 0), diameter (m, required), mass (kg,
    required), species (an integer 0, 1, ... that [[contact.pair]] tables name; default 0).
    All of one length N >= 1."""

    COLUMNS = _PCOLS
    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    omega: np.ndarray
    diameter: np.ndarray
    mass: np.ndarray
    species: np.ndarray | None = None  # None: every particle of species 0

    def __post_init__(self) -> None:
        for k, v in ((k, getattr(self, k)) for k in _PCOLS):
            a = np.array(np.zeros(np.size(self.x)) if v is None else v, dtype=np.float64)
            a.setflags(write=False)
            object.__setattr__(self, k, a)

    def __len__(self) -> int:
        return int(self.x.size)


@dataclass(frozen=True)
class Contact:
    """``[contact]``: normal (the normal law, contact.normal.LAWS: "linear", the paper's
    spring k_n delta, by default), k_n (N/m, 352.1), gamma_n (kg/s, 0.19) or restitution (e_n
    of every contact whatever its masses, the linear law only; "auto": from gamma_n), k_t (N/m,
    267.1), mu (0.44), tangential_restitution (e_t of a sticking contact, instead of
    gamma_t), mu_bottom (2e-5), gravity (m/s^2, 9.81; bottom friction only), height
    (m, disk height h, 6e-3); the optional slots' parameters: gamma_t (kg/s, tangential
    viscous damping, 0), k_r (N/m, rolling spring, 0), mu_r (rolling resistance's
    Coulomb-type coefficient, 0), each only with its [effects] switch; then the other normal
    laws' parameters, each only with its law."""

    normal: str = key("linear", rule="|".join(LAWS))
    k_n: float = key(352.1, "N/m", ">0")
    gamma_n: float = key(0.19, "kg/s", ">=0")
    restitution: float | None = key(None, "", ">0 <=1")
    tangential_restitution: float | None = key(None, "", ">0 <=1")
    k_t: float = key(267.1, "N/m", ">=0")
    mu: float = key(0.44, "", ">=0")
    mu_bottom: float = key(2e-5, "", ">=0")
    gravity: float = key(9.81, "m/s^2", ">0")
    height: float = key(6e-3, "m", ">0")
    gamma_t: float = key(0.0, "kg/s", ">=0")
    k_r: float = key(0.0, "N/m", ">=0")
    mu_r: float = key(0.0, "", ">=0")
    youngs_modulus: float = key(0.0, "Pa", ">0")
    poisson_ratio: float = key(0.0, "", ">-1 <=0.499")
    k_unload: float = key(0.0, "N/m", ">0")
    k_adhesion: float = key(0.0, "N/m", ">=0")


@dataclass(frozen=True)
class PairLaw:
    """``[[contact.pair]]`` (optional): the law of one pair. ``species``: two species names, or a
    species and "inner_ring" or "outer_ring" (its wall disks and flat surface); in a free scene
    two species numbers (the particles' column). Then any [contact] key of a contact (not normal,
    mu_bottom, gravity, height), same units and rules; a key left out takes the [contact]
    value; a pair without a table mixes its partners' own laws (their tables with themselves,
    else [contact]; the rule, the step, k'_n: docs/extending.md)."""

    species: tuple
    values: tuple[tuple[str, float], ...]


@dataclass(frozen=True)
class Effects:
    """``[effects]`` (booleans, same defaults for both kinds): normal_damping (true),
    tangential_friction (true), rotation (true), bottom_friction (true),
    clip_attractive_normal (false), tangential_damping (false: a viscous tangential force
    -gamma_t v_t, with [contact] gamma_t), rolling_resistance (false: a rolling spring k_r with
    its limit mu_r |f_n|, with [contact] k_r and mu_r). An effect that is off is compiled out
    of the step loop (contact.model)."""

    normal_damping: bool = key(True)
    tangential_friction: bool = key(True)
    rotation: bool = key(True)
    bottom_friction: bool = key(True)
    clip_attractive_normal: bool = key(False)
    tangential_damping: bool = key(False)
    rolling_resistance: bool = key(False)


@dataclass(frozen=True)
class TimeCfg:
    """``[time]``: dt (s, or "auto": t_c(smallest pair) / dt_per_contact, shortened by
    at most 1 % to divide a power of ten of a second, 10 ms for the paper's material, so that
    output at multiples of it lands at exactly the times named; default auto), dt_per_contact
    (>= 5, default 50), end (s, 239.0), integrator ("verlet": velocity Verlet whose
    velocity-dependent forces use the velocity predicted at the new step, v + dt/2 a,
    with the damping of a contact that starts or ends within a step weighted by its in-contact
    fraction (default); "verlet-halfstep": plain velocity Verlet with the half-step velocity
    in those forces and no weighting, as in LAMMPS GRANULAR; docs/accuracy.md compares them).
    Either way dt may not exceed t_c/5 nor the largest stable step of the stiffest mode of the
    densest packing the effects enable (translation, with the tangential spring and the
    damping; disks turning alike with friction and rotation; the rolling spring): t_c/11 for
    the paper's material, t_c/9.9 without friction (docs/accuracy.md, "Stability limit");
    ``pardem check`` prints the limit. A run that would take more than 1e12 steps is refused."""

    dt: float | None = key(None, "s", ">0")
    dt_per_contact: float = key(50.0, "", ">=5 <=1e6")
    end: float = key(239.0, "s", ">0")
    integrator: str = key("verlet", rule="verlet|verlet-halfstep")


@dataclass(frozen=True)
class Neighbors:
    """``[neighbors]`` (optional): skin (m, Verlet-list skin; "auto": 0.1 x the
    smallest free-particle diameter; default auto)."""

    skin: float | None = key(None, "m", ">0")


@dataclass(frozen=True)
class OutputCfg:
    """``[output]``: snapshot_interval (s, 1.0), checkpoint_interval (s, 10.0), contacts (write
    force-chain contacts with snapshots, true)."""

    snapshot_interval: float = key(1.0, "s", ">0")
    checkpoint_interval: float = key(10.0, "s", ">0")
    contacts: bool = key(True)


@dataclass(frozen=True)
class AveragingCfg:
    """``[averaging]`` (optional; in-situ ring averaging): start (s, 180.0), end (s, 239.0),
    sample_interval (s, 0.1), ring_width (m; "auto": the smallest free-particle diameter
    / 8, the paper's choice), weighting ("slice" (the
    paper's) | "exact" | "centre" | "gaussian", see averaging/weights.py; default "slice"),
    reference_diameter (m, the d~ of r~ = (r - R_i)/d~ and of the
    v_phi decay length; "auto": the mean free-particle diameter; the paper's scenes
    set 8.0e-3), displacement (the tangential part of the contact displacement Delta in eps and
    kappa: "spring" (default), the elastic Cundall-Strack spring xi, held at the Coulomb cap
    while a contact slides, with which M = (k_t/pi h) kappa . F holds identically; "eta", eq.
    1.3 read literally, the total tangential displacement, which keeps growing while a
    contact slides)."""

    start: float = key(180.0, "s", ">=0")
    end: float = key(239.0, "s")
    sample_interval: float = key(0.1, "s", ">0")
    ring_width: float | None = key(None, "m", ">0")
    weighting: str = key("slice", rule="slice|exact|centre|gaussian")
    reference_diameter: float | None = key(None, "m", ">0")
    displacement: str = key("spring", rule="spring|eta")


@dataclass(frozen=True)
class Scene:
    """A complete validated scene. ``geometry`` and ``species`` are set for couette scenes,
    ``particles`` for free ones; ``averaging`` is None without an ``[averaging]`` table;
    ``pairs``: the [[contact.pair]] tables (partners in species order, a ring second);
    ``source`` is the file it was loaded from (not part of equality or ``to_dict``);
    ``wall_disks``: fixed wall disks (wall_file.py), None without; ``warnings``: the
    [warnings] table (not physics: left out of the fingerprint)."""

    info: SceneInfo
    geometry: Geometry | None
    species: tuple[Species, ...]
    particles: FreeParticles | None
    contact: Contact
    effects: Effects
    time: TimeCfg
    neighbors: Neighbors
    output: OutputCfg
    averaging: AveragingCfg | None
    pairs: tuple[PairLaw, ...] = ()
    source: str | None = field(default=None, compare=False)
    wall_disks: WallDisks | None = None
    warnings: WarningsCfg = WarningsCfg()

    @property
    def n_free(self) -> int:
        """Total number of free (non-wall) particles."""
        if self.particles is not None:
            return len(self.particles)
        return sum(s.count for s in self.species)

    @property
    def min_free_diameter(self) -> float:
        """Smallest free-particle diameter (m); species with count 0 do not count."""
        if self.particles is not None:
            return float(self.particles.diameter.min())
        return float(all_disks(self)[0].min())

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict in the TOML layout, every default filled in."""
        d: dict[str, Any] = {"scene": dataclasses.asdict(self.info)}
        if self.geometry is not None:
            d["geometry"] = {k: "auto" if v is None else v
                             for k, v in dataclasses.asdict(self.geometry).items()}
            d["species"] = [_species_row(s) for s in self.species]
        if self.particles is not None:  # species only when given (older scenes' fingerprints)
            names = [k for k in _PCOLS if k != "species" or self.particles.species.any()]
            cols = [getattr(self.particles, k).tolist() for k in names]
            d["particles"] = [dict(zip(names, row)) for row in zip(*cols)]
        if self.wall_disks is not None:
            d["wall_disks"] = self.wall_disks.rows()
        c = self.contact  # a damping is given as gamma or as a restitution, not both
        damping = {"gamma_n" if c.restitution is not None else "restitution",
                   "gamma_t" if c.tangential_restitution is not None
                   else "tangential_restitution"}
        d["contact"] = {k: v for k, v in dataclasses.asdict(c).items()
                        if k not in foreign_keys(c.normal) and k not in damping}
        if self.pairs:
            d["contact"]["pair"] = [{"species": list(p.species), **dict(p.values)}
                                    for p in self.pairs]
        d["effects"] = dataclasses.asdict(self.effects)
        t = dataclasses.asdict(self.time)
        d["time"] = {**t, "dt": "auto" if t["dt"] is None else t["dt"]}
        d["neighbors"] = {"skin": "auto" if self.neighbors.skin is None else self.neighbors.skin}
        d["output"] = dataclasses.asdict(self.output)
        if self.averaging is not None:
            d["averaging"] = {k: "auto" if v is None else v
                              for k, v in dataclasses.asdict(self.averaging).items()}
        d["warnings"] = dataclasses.asdict(self.warnings)
        return d

    def fingerprint(self) -> str:
        """sha256 hex of the physics: to_dict() without scene.name, time.end, [output],
        [averaging] and [warnings], which may legitimately change on a restart, and without
        keys added since the first release while they hold their default (``_LATER``), so
        that older checkpoints stay restartable."""
        text = json.dumps(self.physics(), sort_keys=True, separators=(",", ":"),
                          allow_nan=False)
        return hashlib.sha256(text.encode()).hexdigest()

    def physics(self) -> dict:
        """What the fingerprint covers, as a dict in the TOML layout (checkpoints keep it, so
        that a refused restart can name the keys that differ)."""
        d = self.to_dict()
        d["scene"].pop("name")
        d["time"].pop("end")
        for (table, key), default in _LATER.items():
            if table in d and d[table][key] == default:
                d[table].pop(key)
        for table in ("output", "averaging", "warnings"):
            d.pop(table, None)
        return d


def _species_row(s: Species) -> dict[str, Any]:
    """A resolved species as its table: the count, not the share; the mass or the density as
    given; a distribution's keys only if it has one (so older scenes' fingerprints hold)."""
    given = "mass" if s.mass is not None and s.density is None else "density"
    return {k: v for k, v in dataclasses.asdict(s).items() if v is not None and k != "share"
            and k in (given, "name", "count") + (("diameter_distribution",) + SHAPE_KEYS
                                                 if s.distributed else ("diameter",))}


_LATER = {("time", "integrator"): "verlet",
          **{("geometry", f"{ring}_{key}"): default for ring in ("inner", "outer")
             for key, default in (("wall_count", "auto"), ("wall_diameter", "auto"),
                                  ("flat_surface", True))},
          ("effects", "tangential_damping"): False, ("effects", "rolling_resistance"): False,
          ("contact", "normal"): "linear", ("contact", "gamma_t"): 0.0, ("contact", "k_r"): 0.0,
          ("contact", "mu_r"): 0.0,
          ("geometry", "volume_fraction"): "auto"}
"""Keys added after the first release, with their defaults (see Scene.fingerprint)."""

"""What each scene key means, in one line, for the input reference (docs/input.md, written by
``run_scripts/tools/input_reference.py``) and whoever else explains a key to a user.

Stage: input (documentation only; nothing here is checked or read by a run). The kind, unit,
default and allowed values of a key are declared once, in ``scene.py``; this module adds only
the words: ``KEYS[(table, key)]``, and ``TABLES[table]``, a short paragraph of the context a
table's keys share. ``tests/test_key_docs.py`` checks that every key the schema accepts has a
line here and that no line describes a key that does not exist. Written for a physicist, in
TOML's terms ("auto", true / false), with [links](page.md) to the manual's pages, and without
``|`` (a Markdown table's separator).
"""

from __future__ import annotations

TABLES = {
    "scene": "What the scene is: its kind, its name and the seed of its randomness.",
    "geometry": (
        "The annulus between a rotating inner ring and a fixed outer ring that is moved in from "
        "`outer_start_radius` to `outer_radius` during the compression. Each ring carries glued "
        "wall disks; keys starting with `inner_` or `outer_` set one ring's layout. Wall disks "
        "may overlap (a spacing below their diameter); the outer ring's disks keep the spacing "
        "of its final radius and move radially with it."),
    "species": (
        "One table per kind of disk, placed at random in the annulus. Give `count` for every "
        "species, or `[geometry] volume_fraction` and a `share` for every species: the counts "
        "are then the nearest integers to share / sum(shares) × the number of disks that fill "
        "the cell to that fraction (the resolved scene, `pardem check`, shows them)."),
    "contact": (
        "The contact law between two disks and between a disk and a ring. The optional slots "
        "(`gamma_t`, `k_r`, `mu_r`) are allowed only with their `[effects]` switch on; the "
        "parameters of a normal law other than `linear` only with that law."),
    "contact.pair": (
        "The contact law of one pair of species, where it differs from `[contact]`. A key left "
        "out takes the `[contact]` value; a pair without a table mixes its two species' own "
        "laws ([Parameters per pair of species](extending.md#parameters-per-pair-of-species))."),
    "effects": (
        "Switches of the physics, the same defaults for both kinds of scene. An effect that is "
        "off costs nothing: it is compiled out of the time-step loop."),
    "time": (
        "The time step is at most t_c/5 and at most the largest stable step of the stiffest "
        "mode the effects enable (t_c/11 for the paper's material, t_c/9.9 without friction; "
        "[What accuracy costs](accuracy.md), \"Stability limit\"); `pardem check` prints the "
        "limit. A run of more than 10¹² steps is refused."),
    "neighbors": "The Verlet neighbour lists.",
    "output": "What a run writes into its folder, and how often ([Output files](output.md)).",
    "averaging": (
        "Ring averages taken while the run goes ([Ring averages](averaging.md)); without this "
        "table none are taken (`pardem average` can take them from the snapshots later)."),
    "warnings": (
        "When a run warns that a legal value looks physically suspicious ([Warnings]"
        "(warnings.md)). A warning never stops a run; `false` switches a threshold off."),
    "particles": (
        "Free scenes only: the particles, as `[[particles]]` tables (one per particle, its id "
        "its place in the list) or as `particles_file = \"FILE\"`, a `.csv` file with a header "
        "line naming the columns or an `.h5` file with one dataset per column, relative to the "
        "scene file's folder. At least one particle."),
    "wall_disks": (
        "Free scenes only, optional: disks that never move, infinitely massive (a boundary: "
        "[Adding a boundary](extending.md)), as `[[wall_disks]]` tables or `wall_disks_file = "
        "\"FILE.csv\"` with the header `x,y,diameter` (`#` comment lines allowed). They follow "
        "the free particles in id order; no free particle may start more than 1 % of the "
        "smaller diameter into one."),
}

KEYS = {
    ("scene", "kind"): "`couette`: disks of the `[[species]]` between two rings, the paper's "
                       "cell; `free`: explicit particles, no rings",
    ("scene", "name"): "the run's name: its default output folder is `runs/NAME`",
    ("scene", "seed"): "seed of the random placement; a particle's randomness depends only on "
                       "the seed and its id, not on the number of ranks",
    ("geometry", "inner_radius"): "radius R_i of the inner ring's surface",
    ("geometry", "outer_radius"): "radius R_o of the outer ring's surface after the compression",
    ("geometry", "outer_start_radius"): "radius of the outer ring at t = 0, a dilute start",
    ("geometry", "compression_time"): "time over which the outer ring moves in (a cosine ramp)",
    ("geometry", "omega_inner"): "angular velocity of the inner ring, counter-clockwise "
                                 "positive, from t = 0",
    ("geometry", "wall_particle_diameter"): "diameter of the glued wall disks of both rings",
    ("geometry", "wall_particle_spacing"): "distance between neighbouring wall disks' centres "
                                           "along a ring",
    ("geometry", "inner_wall_count"): "wall disks on the inner ring; 0: a smooth ring; "
                                      "\"auto\": 2π R_i / spacing, rounded, at least 1",
    ("geometry", "outer_wall_count"): "wall disks on the outer ring; 0: a smooth ring; "
                                      "\"auto\": 2π R_o / spacing, rounded, at least 1",
    ("geometry", "inner_wall_diameter"): "diameter of the inner ring's wall disks; "
                                         "\"auto\": `wall_particle_diameter`",
    ("geometry", "outer_wall_diameter"): "diameter of the outer ring's wall disks; "
                                         "\"auto\": `wall_particle_diameter`",
    ("geometry", "inner_flat_surface"): "true: the inner ring's flat surface behind its wall "
                                        "disks touches disks too; false: only its wall disks",
    ("geometry", "outer_flat_surface"): "true: the outer ring's flat surface behind its wall "
                                        "disks touches disks too; false: only its wall disks",
    ("geometry", "volume_fraction"): "fill the cell to this area fraction (free disks and half "
                                     "of each wall disk over π(R_o² − R_i²), the paper's ν̄); "
                                     "at most 0.9069 for one diameter, 1 for several; \"auto\": "
                                     "the species' counts decide",
    ("species", "name"): "the species' name, unique; `[[contact.pair]]` tables name it",
    ("species", "diameter"): "disk diameter; required unless a `diameter_distribution` is given",
    ("species", "diameter_distribution"): "`fixed` (every disk has `diameter`), `uniform` "
                                          "(diameters uniform between `diameter_min` and "
                                          "`diameter_max`) or `lognormal` (ln d normal with "
                                          "`diameter_median` and `diameter_sigma`); drawn from "
                                          "`[scene] seed`; needs `density`",
    ("species", "diameter_min"): "smallest diameter: uniform's lower end, a log-normal's "
                                 "optional truncation",
    ("species", "diameter_max"): "largest diameter: uniform's upper end, a log-normal's "
                                 "optional truncation",
    ("species", "diameter_median"): "a log-normal's median diameter",
    ("species", "diameter_sigma"): "a log-normal's standard deviation of ln d",
    ("species", "mass"): "mass of one disk; required unless `density` is given",
    ("species", "density"): "instead of `mass`: the density of the disks' material, mass = "
                            "density × π (d/2)² h with h the `[contact] height`",
    ("species", "count"): "number of disks; required unless `[geometry] volume_fraction` is set",
    ("species", "share"): "with `[geometry] volume_fraction` instead of `count`: the species' "
                          "part of the disks by number, in any unit (2545 and 394, or 0.866 "
                          "and 0.134)",
    ("contact", "normal"): "the normal law (the table below); `linear`: the paper's spring "
                           "k_n δ",
    ("contact", "k_n"): "normal spring stiffness (`linear`, `luding`: its loading branch)",
    ("contact", "gamma_n"): "normal viscous damping coefficient: a force −γ_n v_n (not with "
                            "`restitution`)",
    ("contact", "restitution"): "instead of `gamma_n` (`linear` law): the normal restitution "
                                "coefficient e_n of every contact, whatever its masses (each "
                                "pair's γ_n follows from its masses); \"auto\": from `gamma_n`",
    ("contact", "k_t"): "tangential (Cundall–Strack) spring stiffness",
    ("contact", "tangential_restitution"): "instead of `gamma_t` (`linear` and `luding` laws, "
                                           "turning disks): the restitution e_t of a sticking "
                                           "contact's tangential oscillation, whatever its "
                                           "masses (γ_t = β(e_t) √(k_t m_red/3))",
    ("contact", "mu"): "Coulomb friction coefficient: the tangential force is at most μ f_n",
    ("contact", "mu_bottom"): "friction coefficient of the disks on the cell's bottom plate",
    ("contact", "gravity"): "gravity pressing the disks on the bottom plate (bottom friction "
                            "only)",
    ("contact", "height"): "disk height h, the 2D stresses' third dimension",
    ("contact", "gamma_t"): "tangential viscous damping: a force −γ_t v_t "
                            "(`[effects] tangential_damping`)",
    ("contact", "k_r"): "rolling spring stiffness (`[effects] rolling_resistance`)",
    ("contact", "mu_r"): "rolling resistance's limit: the rolling spring's force is at most "
                         "μ_r f_n (`[effects] rolling_resistance`)",
    ("contact", "youngs_modulus"): "Young's modulus E of the disks' material (`hertz`)",
    ("contact", "poisson_ratio"): "Poisson's ratio ν of the disks' material (`hertz`)",
    ("contact", "k_unload"): "stiffness of the unloading and reloading branch (`luding`), "
                             "at least `k_n`",
    ("contact", "k_adhesion"): "adhesive (tensile) stiffness: the pull −k_adhesion δ "
                               "(`luding`); at most m_red (π/(5 dt))² of the lightest pair, "
                               "so that the step resolves the tension branch (about 100 "
                               "`k_unload` at the default dt)",
    ("contact.pair", "species"): "the pair: two species names, or a species and `inner_ring` "
                                 "or `outer_ring` (that ring's wall disks and flat surface); in "
                                 "a free scene two species numbers",
    ("effects", "normal_damping"): "the normal viscous damping −γ_n v_n",
    ("effects", "tangential_friction"): "the tangential spring with its Coulomb limit",
    ("effects", "rotation"): "disks turn under the contacts' torques (false: spins stay zero)",
    ("effects", "bottom_friction"): "Coulomb friction μ_b m g of each disk on the bottom plate",
    ("effects", "clip_attractive_normal"): "a normal force that the damping would make "
                                           "attractive is set to zero",
    ("effects", "tangential_damping"): "a viscous tangential force −γ_t v_t (`[contact] "
                                       "gamma_t`)",
    ("effects", "rolling_resistance"): "a rolling spring k_r with its limit μ_r f_n "
                                       "(`[contact] k_r`, `mu_r`)",
    ("time", "dt"): "time step; \"auto\": t_c / `dt_per_contact` for the stiffest pair, "
                    "shortened by at most 1 % so that output times fall on steps",
    ("time", "dt_per_contact"): "time steps per contact time t_c when `dt` is \"auto\"",
    ("time", "end"): "simulated time at which the run ends",
    ("time", "integrator"): "`verlet`: velocity Verlet with the forces at the predicted "
                            "velocity, contacts' damping weighted within a step; "
                            "`verlet-halfstep`: LAMMPS GRANULAR's (see [accuracy](accuracy.md))",
    ("neighbors", "skin"): "margin of the Verlet lists; \"auto\": 0.1 × the smallest free "
                           "diameter",
    ("output", "snapshot_interval"): "time between snapshots (particles and contacts)",
    ("output", "checkpoint_interval"): "time between checkpoints (the state a restart reads)",
    ("output", "contacts"): "write each snapshot's contacts (force chains) too",
    ("averaging", "start"): "time of the first sample",
    ("averaging", "end"): "time of the last sample, after `start`",
    ("averaging", "sample_interval"): "time between samples",
    ("averaging", "ring_width"): "width of the rings; \"auto\": the smallest free diameter / 8, "
                                 "the paper's",
    ("averaging", "weighting"): "a disk's share of a ring: `slice` (the paper's: its area on "
                                "one side of a straight chord in place of the ring's circle), "
                                "`exact` (its area inside the ring), `centre` (all of it where "
                                "its centre is), `gaussian` (a normal kernel of width a/2)",
    ("averaging", "reference_diameter"): "the d̃ of r̃ = (r − R_i)/d̃ and of the velocity's "
                                         "decay length; \"auto\": the mean free diameter",
    ("averaging", "displacement"): "tangential part of the contact displacement Δ: `spring`, "
                                   "the elastic spring ξ; `eta`, the total tangential "
                                   "displacement η (eq. 1.3 read literally)",
    ("warnings", "overlap"): "warn when the largest overlap exceeds this fraction of the "
                             "smaller diameter (once in the compression, once after); a run "
                             "stops anyway at 0.25",
    ("warnings", "mass_ratio"): "warn when the densities m / (π a²) the species' masses imply "
                                "lie further apart than this factor",
    ("warnings", "oversubscribe"): "true: more ranks than cores is intended (no warning)",
    ("particles", "x"): "centre's x",
    ("particles", "y"): "centre's y",
    ("particles", "vx"): "velocity's x component",
    ("particles", "vy"): "velocity's y component",
    ("particles", "omega"): "angular velocity, counter-clockwise positive",
    ("particles", "diameter"): "diameter",
    ("particles", "mass"): "mass",
    ("particles", "species"): "species number 0, 1, …, which `[[contact.pair]]` tables name",
    ("wall_disks", "x"): "centre's x",
    ("wall_disks", "y"): "centre's y",
    ("wall_disks", "diameter"): "diameter",
}

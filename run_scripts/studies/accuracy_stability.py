"""The accuracy study's section on the stability limit (run_scripts/studies/accuracy_study.py):
where the default step sits against the limit, the text of section 6 and its table, made
from stability.json (written by stability_table.py).
"""

from __future__ import annotations

import json
from pathlib import Path


def stability_line(ns) -> str:
    """Where the default step sits against the stability limit of the paper's material (from
    the scene, pardem.core.stability.stability_limit; ``ns``: table 1's dt = t_c/N)."""
    from pardem.input.scene_file import load_scene
    from pardem.core.scales import smallest_contact_time
    from pardem.core.stability import stability_limit

    scene = load_scene(Path(__file__).resolve().parents[1] / "scenes" / "couette_B.toml")
    t_c = smallest_contact_time(scene)
    limit, mode = stability_limit(scene)
    return (f"- **the stability limit** is dt ≤ t_c/{t_c / limit:.3g} for the paper's material "
            f"(`pardem check` prints it): the largest stable step of its stiffest mode, "
            f"{mode} (section \"Stability limit\" below). The default t_c/50 "
            f"sits {50 / (t_c / limit):.3g}× below it, table 1's coarsest t_c/{min(ns)} "
            + (f"{min(ns) / (t_c / limit):.2g}× below." if min(ns) * limit >= t_c else
               f"{t_c / limit / min(ns):.2g}× above (measured before the limit was corrected; "
               "it is refused now)."))


STABILITY = """\
`pardem check` prints the limit, and a larger step is refused. It is the smallest of t_c/5 (a
collision resolved in fewer steps leaves an elastic gas's energy drifting although nothing is
unstable; it binds only without damping and friction) and the largest stable step of each mode
of the densest packing that the effects enable (`pardem.core.stability.contact_modes`).

**One mode.** x'' = −ω_v² x − ω_e² ξ − c x', ξ' = x': pardem's velocity Verlet moves x with the
half-step velocity, but evaluates the damping and increments the springs ξ (tangential,
rolling) with the velocity predicted at the end of the step. Its amplification matrix reaches
the eigenvalue −1 where W² dt² + 4c dt = 4 with W² = ω_v² + 2ω_e², and no other boundary
first: dt* = 2(√(c² + W²) − c)/W². That is 2/ω for a plain spring, √2/ω for an explicitly
incremented one (the extra instability: half the stiffness is enough) and 1/c for damping
alone (`tests/hard/test_stability_hard.py` checks it against the matrix).

**The stiffest modes** are those of the hexagonal packing of the lightest disks, six contacts
60° apart (by the Rayleigh quotient no packing of such disks is stiffer; a ring or a wall disk,
of infinite mass, gives a contact k/m_i instead of k/m_red, less):

- *translation*: k_n and the sticking k_t both push the centres, with or without rotation:
  W² = 3(k_n + 2k_t)/m_red, c = 3(γ_n + γ_t)/m_red (the M-point mode attains 3k_n/m_red). The
  damping grows with the stiffness, so this mode is also the most damped: ζ = 0.75 against
  the pair's 0.43, and the explicit damping sets its limit.
- *gears* (rotation and friction): every disk turning alike, each contact slipping by 2aθ:
  ω_e² = 12k_t/m_red, four times the pair's 3k_t/m_red.
- *rolling*: each contact adds its pair's k_r a'²(1/I_i + 1/I_j), six of them; on a flat ring
  surface 2k_r/m_i (a' = a, the ring does not turn) and four neighbours.

The rule before took five steps per half period of the stiffest *pair* mode. Without rotation
the pair's tangential mode, k_t/m_red, is softer than the normal one, so it admitted t_c/5,
but in a packing the translation carries both springs, the tangential one explicitly, and the
damping is explicit too: t_c/11.1 is the largest stable step for the paper's material (set
E below; issue 51 saw 100× the kinetic energy at t_c/5.1), and t_c/9.9 without friction (F),
where t_c/5 was admitted as well; with rotation (A) t_c/8.4 was admitted. The default t_c/50
is 4.5× below the limit.

**Measured** (`python run_scripts/studies/stability_table.py --json docs/accuracy/stability.json`):
340 small disks compressed into a small cell (R_i = 0.05 m, R_o 0.11 → 0.09 m in 0.1 s,
ν ≈ 0.84, about four contacts per disk, overlaps up to 8 % d), not sheared; the median kinetic
energy of the free disks 0.2–0.3 s after the compression at each multiple of the limit, over
that at t_c/50. Up to the limit a damped packing comes to rest as at t_c/50: the ratios stay
within the scatter of settled states reached along other paths (up to 13×: a frictionless
packing keeps rearranging now and then). At 1.25× the limit the drift begins: a packing that
no longer comes to rest, 10²–10⁵×, or a run the watchdog stops (inf). Without damping (G) the
gears set the limit and the drift begins only at 1.6×: real packings have fewer than six
contacts per disk, and their gear modes are softer than the hexagonal packing's. Sets with the
rolling spring (k_r = 10⁴ N/m, stiff enough to set the limit; μ_r = 1000, as at μ_r = 1 its cap
holds a growing mode to a chatter of 4–12× at 1.6×) get random spins of 1 rad/s when the
compression ends: a rolling mode needs a seed. D equals F bit for bit: without friction or
rolling nothing turns a disk. Without any dissipation t_c/5 binds; this cell cannot measure
that set (its compression heats the elastic gas until collisions pass 25 % of d, and the run
stops), table 1's elastic gas does. Table 1's t_c/10 rows were measured before this limit.
"""


def stability_section(data: Path) -> list[str]:
    """Section 6: the stability limit's derivation and the measured table
    (run_scripts/studies/stability_table.py --json DATA; the derivation alone without it)."""
    import stability_table

    md = ["## 6. Stability limit", "", STABILITY]
    if data.exists():
        md += stability_table.markdown(json.loads(data.read_text())) + [""]
    return md

"""Prepare one packing, shear it at two friction coefficients, average, plot, open in xarray.

    python examples/prepare_and_branch.py                    # examples/small_dense.toml, ~1 min
    python examples/prepare_and_branch.py SCENE.toml --prepare 5 --end 10 --out runs/branches

The same protocol from the command line: ``pardem run SCENE.toml --from runs/prepared``
(docs/running.md). tests/test_examples.py runs this script on a tiny cell, so it stays
current. Needs pandas and xarray (``pip install -e ".[data]"``).
"""

import argparse
import dataclasses
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no window
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pardem  # noqa: E402
from averaging import ring_dataset, ring_frame  # noqa: E402


def prepare_and_branch(scene_file, out, prepare, end, mus=(0.1, 0.8)):
    """Run ``scene_file`` to ``prepare`` s into ``out/prepared``, then branch it at each
    friction coefficient in ``mus`` to ``end`` s, ring-averaged from ``prepare`` to ``end``.
    Returns ({mu: xarray.Dataset of the ring fields}, {mu: mean inner-ring torque in N m})."""
    out = Path(out)
    scene = pardem.load_scene(scene_file)

    # 1. Prepare: compress the packing and shear it once (no averages yet).
    prepared = dataclasses.replace(scene, averaging=None)
    pardem.Simulation(prepared, out_dir=out / "prepared", overwrite=True).run(end=prepare,
                                                                             progress=False)

    # 2. Branch: the prepared state (positions, velocities, spins, springs, the ring's angle)
    #    with another mu; each branch averages over its own shearing, prepare .. end.
    fields, torques = {}, {}
    for mu in mus:
        branch = dataclasses.replace(
            scene, contact=dataclasses.replace(scene.contact, mu=mu),
            averaging=dataclasses.replace(scene.averaging, start=prepare, end=end))
        folder = out / f"mu{mu}"
        sim = pardem.Simulation(branch, out_dir=folder, branch=out / "prepared", overwrite=True)
        sim.run(end=end, progress=False)
        torques[mu] = float(np.mean(sim.rings.torques))

        # 3. The ring averages as an xarray.Dataset (dims ring; coordinates r, r_tilde) and
        #    as a tidy pandas frame, units in the attributes.
        fields[mu] = ring_dataset(folder)
        frame = ring_frame(folder)
        print(f"mu = {mu}: inner-ring torque {torques[mu]:.3g} N m, "
              f"{len(frame)} rings, v_phi in {frame.attrs['units']['v_phi']}")

    # 4. Plot the velocity profiles with their standard errors.
    fig, ax = plt.subplots(figsize=(5, 3.5))
    for mu, ds in fields.items():
        ax.errorbar(ds["r_tilde"], ds["v_phi"], yerr=ds["v_phi_err"], label=f"μ = {mu}")
    ax.set_xlabel("r̃ = (r − R_i) / d̃")
    ax.set_ylabel(f"v_φ ({fields[mus[0]]['v_phi'].attrs['unit']})")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "v_phi.png", dpi=120)
    plt.close(fig)
    return fields, torques


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default="examples/small_dense.toml")
    parser.add_argument("--out", default="runs/branches")
    parser.add_argument("--prepare", type=float, default=5.0, help="s: the prepared state")
    parser.add_argument("--end", type=float, default=10.0, help="s: the branches' end")
    args = parser.parse_args()
    prepare_and_branch(args.scene, args.out, args.prepare, args.end)
    print(f"{args.out}/v_phi.png")

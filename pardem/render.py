"""``pardem render``: off-screen PNG pictures of a run folder with pyvista (no display needed).

    pardem render RUN_DIR [--snapshot INDEX] [--color speed|spin]
                          [--fields nu v_phi tr_sigma mu_c] [--size 1200] [--out DIR]

Writes into DIR (default RUN_DIR/figures):
- ``snapshot_NNNNNN_<color>.png``: the disks at their radius, coloured by speed |v| (m/s) or spin
  omega (rad/s); wall disks grey;
- ``snapshot_NNNNNN_forces.png``: the force-chain network, each touching contact a bar between
  the two centres whose width and colour scale with its normal force (N), over faint disks;
- ``rings_<field>.png``: ring fields from rings.vtu (or offline/rings.vtu) on the annulus.

Colour bars carry the unit; colour limits ignore the most extreme 2 % of the values (a few
outlier rings or one fast disk would wash out the rest), and say so when they clip. Any scene
kind: free scenes have no wall disks and no rings.

Stage: output (a viewer; nothing here changes a run). Needs the ``viz`` extra (pyvista). Without a display VTK renders through EGL (Mesa); a machine
without libEGL needs ``apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri`` (or libosmesa6 and
VTK_DEFAULT_OPENGL_WINDOW=vtkOSOpenGLRenderWindow).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

if not os.environ.get("DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import pyvista as pv  # noqa: E402

from averaging.fields import FIELD_UNITS  # noqa: E402

from .output.snapshots import read_snapshots  # noqa: E402

pv.OFF_SCREEN = True
WALL_GREY = "#9a9a9a"
BAR = {"vertical": True, "position_x": 0.87, "position_y": 0.25, "height": 0.5}


def disks(snap: dict, mask: np.ndarray) -> pv.PolyData:
    """Filled disks of the snapshot's radii for the rows in mask."""
    pos = np.column_stack([snap["position"][mask], np.zeros(mask.sum())])
    cloud = pv.PolyData(pos)
    cloud["radius"] = snap["radius"][mask]
    return cloud.glyph(geom=pv.Disc(inner=0.0, outer=1.0, c_res=24), scale="radius",
                       orient=False, factor=1.0)


def force_bars(snap: dict, max_width: float) -> pv.PolyData:
    """One quad per touching contact between the two centres; width proportional to the
    (compressive part of the) normal force, max_width (m) for the largest."""
    c = snap["contacts"]
    p = snap["position"][c["cells"][:, 0]]
    q = snap["position"][c["cells"][:, 1]]
    fn = np.maximum(c["normal_force"], 0.0)
    half = 0.5 * max_width * fn / max(fn.max(), 1e-300)
    d = q - p
    t = np.column_stack([-d[:, 1], d[:, 0]]) / np.hypot(d[:, 0], d[:, 1])[:, None]
    corners = np.stack([p + half[:, None] * t, q + half[:, None] * t, q - half[:, None] * t,
                        p - half[:, None] * t], axis=1).reshape(-1, 2)
    faces = np.column_stack([np.full(len(fn), 4), np.arange(4 * len(fn)).reshape(-1, 4)])
    bars = pv.PolyData(np.column_stack([corners, np.zeros(len(corners))]), faces.ravel())
    bars.cell_data["f_n (N)"] = fn
    return bars


def _plotter(size: int) -> pv.Plotter:
    # extra width on the right keeps the colour bar off the annulus
    pl = pv.Plotter(off_screen=True, window_size=(int(1.25 * size), size))
    pl.set_background("white")
    return pl


def _limits(values: np.ndarray, symmetric: bool) -> tuple[float, float, bool]:
    """Colour limits that leave out the most extreme 2 % of the finite values: 0 to the 98th
    percentile for values >= 0, +- the 98th percentile of |v| when ``symmetric``, the 1st to
    99th otherwise; and whether some values lie outside them."""
    v = values[np.isfinite(values)]
    if not v.size:
        return 0.0, 1.0, False
    if symmetric:
        top = float(np.percentile(np.abs(v), 98)) or float(np.abs(v).max()) or 1.0
        lo, hi = -top, top
    elif v.min() >= 0:
        lo, hi = 0.0, float(np.percentile(v, 98)) or float(v.max()) or 1.0
    else:
        lo, hi = (float(x) for x in np.percentile(v, [1, 99]))
        if hi <= lo:
            lo, hi = float(v.min()), float(v.max()) + 1e-300
    return lo, hi, bool(np.any((v < lo) | (v > hi)))


def _title(name: str, unit: str, clipped: bool) -> str:
    return f"{name} ({unit})" + (" [clipped]" if clipped else "")


def _text(pl: pv.Plotter, text: str, size: int) -> None:
    # a pixel position inside the window: "upper_left" clips the first line on some builds
    pl.add_text(text, position=(int(0.02 * size), int(0.94 * size)), font_size=10,
                color="black")


def _save(pl: pv.Plotter, path: Path) -> Path:
    pl.view_xy()
    pl.enable_parallel_projection()
    pl.camera.tight(padding=0.02, adjust_render_window=False)
    shift = (0.22 * pl.camera.parallel_scale, 0.0, 0.0)  # picture left, colour bar right
    pl.camera.focal_point = tuple(np.add(pl.camera.focal_point, shift))
    pl.camera.position = tuple(np.add(pl.camera.position, shift))
    pl.screenshot(str(path))
    pl.close()
    return path


def render_snapshot(snap: dict, out: Path, color: str, size: int) -> list[Path]:
    free = snap["kind"] == 0
    name = f"snapshot_{snap['index']:06d}"
    title = f"t = {snap['time']:.2f} s"
    values, unit = {"speed": (np.hypot(*snap["velocity"][free].T), "m/s"),
                    "spin": (snap["omega"][free], "rad/s")}[color]
    pl = _plotter(size)
    grains = disks(snap, free)
    grains["c"] = np.repeat(values, grains.n_points // max(free.sum(), 1))
    lo, hi, clipped = _limits(values, symmetric=color == "spin")
    pl.add_mesh(grains, scalars="c", cmap="viridis" if color == "speed" else "coolwarm",
                clim=(lo, hi), scalar_bar_args={"title": _title(color, unit, clipped), **BAR})
    if (~free).any():  # free scenes have no wall disks
        pl.add_mesh(disks(snap, ~free), color=WALL_GREY)
    _text(pl, title, size)
    paths = [_save(pl, out / f"{name}_{color}.png")]
    if "contacts" in snap and len(snap["contacts"]["normal_force"]):
        pl = _plotter(size)
        pl.add_mesh(disks(snap, np.ones_like(free)), color="#e8e8e8")
        pl.add_mesh(force_bars(snap, 1.2 * float(snap["radius"][free].min())), cmap="inferno_r",
                    scalar_bar_args={"title": "f_n (N)", **BAR})
        _text(pl, title + ", force chains", size)
        paths.append(_save(pl, out / f"{name}_forces.png"))
    return paths


def render_rings(vtu: Path, out: Path, fields: list[str], size: int) -> list[Path]:
    mesh = pv.read(vtu)
    paths = []
    for field in fields:
        if field not in mesh.cell_data:
            raise SystemExit(f"pardem render: {vtu} has no field {field!r}; it has "
                             f"{', '.join(sorted(mesh.cell_data))}")
        values = np.asarray(mesh.cell_data[field], float)
        lo, hi, clipped = _limits(values.ravel() if values.ndim == 1 else
                                  np.linalg.norm(values, axis=-1), symmetric=False)
        unit = FIELD_UNITS.get(field, "")
        pl = _plotter(size)
        pl.add_mesh(mesh, scalars=field, cmap="viridis", nan_color="white", clim=(lo, hi),
                    scalar_bar_args={"title": _title(field, unit or "1", clipped), **BAR})
        paths.append(_save(pl, out / f"rings_{field}.png"))
    return paths


def render(args) -> int:
    """The pictures ``args`` (cli.py's ``render`` options) ask for; 1 if there was nothing to
    draw."""
    out = args.out or args.run_dir / "figures"
    out.mkdir(parents=True, exist_ok=True)
    written = []
    snaps = list(read_snapshots(args.run_dir))
    if snaps:
        try:
            snap = snaps[args.snapshot]
        except IndexError:
            raise SystemExit(f"pardem render: --snapshot {args.snapshot}: the run has "
                             f"{len(snaps)} snapshots (0..{len(snaps) - 1})") from None
        snap["index"] = args.snapshot % len(snaps)
        written += render_snapshot(snap, out, args.color, args.size)
    for vtu in (args.run_dir / "rings.vtu", args.run_dir / "offline" / "rings.vtu"):
        if vtu.exists() and args.fields:
            written += render_rings(vtu, out, args.fields, args.size)
            break
    for p in written:
        print(p)
    return 0 if written else 1

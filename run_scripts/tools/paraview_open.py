"""Open a pardem run folder in ParaView with sensible defaults.

    paraview --script=run_scripts/tools/paraview_open.py      (asks nothing: set RUN below or
                                                              PARDEM_RUN=runs/quick in the
                                                              environment)
    pvpython run_scripts/tools/paraview_open.py RUN_DIR [PNG]  (batch: also saves a screenshot)

Loads particles.xdmf (disks drawn as filled circles of their true radius, coloured by speed),
contacts.xdmf (force chains: lines coloured by normal force, hidden at first) and rings.vtu
(ring fields, coloured by nu, hidden at first), jumps to the last snapshot and looks down the
cell axis. Runs inside ParaView's own Python (pvpython/pvbatch or the GUI's script option),
not in the pardem venv.
"""

import os
import sys

from paraview.simple import (ColorBy, GetActiveViewOrCreate, GetAnimationScene, Glyph, Hide,
                             OpenDataFile, Render, ResetCamera, SaveScreenshot, Show)

RUN = sys.argv[1] if len(sys.argv) > 1 else os.environ.get("PARDEM_RUN", "runs/quick")
view = GetActiveViewOrCreate("RenderView")
particles = OpenDataFile(os.path.join(RUN, "particles.xdmf"))
scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
scene.AnimationTime = scene.EndTime
disks = Glyph(Input=particles, GlyphType="2D Glyph")
disks.GlyphType.GlyphType = "Circle"
disks.GlyphType.Filled = 1
disks.ScaleArray = ["POINTS", "radius"]
disks.ScaleFactor = 2.0  # the 2D glyph is a circle of unit diameter
disks.GlyphMode = "All Points"
disks.OrientationArray = ["POINTS", "No orientation array"]
shown = Show(disks, view)
ColorBy(shown, ("POINTS", "velocity", "Magnitude"))
shown.RescaleTransferFunctionToDataRange(True, False)
shown.SetScalarBarVisibility(view, True)

if os.path.exists(os.path.join(RUN, "contacts.xdmf")):
    chains = OpenDataFile(os.path.join(RUN, "contacts.xdmf"))
    c = Show(chains, view)
    ColorBy(c, ("CELLS", "normal_force"))
    c.LineWidth = 2.0
    Hide(chains, view)

for rings_path in (os.path.join(RUN, "rings.vtu"), os.path.join(RUN, "offline", "rings.vtu")):
    if os.path.exists(rings_path):
        rings = OpenDataFile(rings_path)
        r = Show(rings, view)
        ColorBy(r, ("CELLS", "nu"))
        Hide(rings, view)
        break

view.InteractionMode = "2D"
view.CameraPosition = [0.0, 0.0, 1.0]
view.CameraFocalPoint = [0.0, 0.0, 0.0]
view.CameraViewUp = [0.0, 1.0, 0.0]
ResetCamera(view)
Render(view)
if len(sys.argv) > 2:
    SaveScreenshot(sys.argv[2], view, ImageResolution=[900, 900])

"""Run by ParaView's own Python (pvbatch), not by pytest: open a run folder's files with
ParaView's default readers at the last time step and print one JSON line per file."""

import json
import sys

from paraview import servermanager as sm
from paraview.simple import OpenDataFile

run = sys.argv[1]
for name in ("particles.xdmf", "contacts.xdmf", "rings.vtu"):
    src = OpenDataFile(f"{run}/{name}")
    times = list(getattr(src, "TimestepValues", None) or [])
    src.UpdatePipeline(times[-1] if times else 0.0)
    data = sm.Fetch(src)
    if data.IsA("vtkMultiBlockDataSet"):
        data = data.GetBlock(0)
    pd, cd = data.GetPointData(), data.GetCellData()
    print(json.dumps({
        "file": name, "reader": src.GetXMLName(), "times": len(times),
        "points": data.GetNumberOfPoints(), "cells": data.GetNumberOfCells(),
        "point_arrays": sorted(pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())),
        "cell_arrays": sorted(cd.GetArrayName(i) for i in range(cd.GetNumberOfArrays()))}))

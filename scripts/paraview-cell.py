#!/usr/bin/python3
"""Opens the relaxed unit cell that `dea-mpi fabric` wrote (OUT/cell.xdmf) in ParaView
(Debian's paraview, headless), checks its fibres against OUT/fabric.json and renders it
coloured by direction to a PNG. Without a display it runs on its own Xvfb
(scripts/virtual_display.py):

    /usr/bin/python3 scripts/paraview-cell.py OUT [IMAGE.png]

Exits non-zero with a message when something is missing.
"""
import json
import os
import sys

from virtual_display import ensure_display

ensure_display()  # before ParaView looks for a display
from paraview.simple import ColorBy, GetActiveViewOrCreate, Render, SaveScreenshot, Show, XDMFReader
from paraview import servermanager

out = sys.argv[1]
image = sys.argv[2] if len(sys.argv) > 2 else os.path.join(out, "cell.png")
with open(os.path.join(out, "fabric.json")) as f:
    report = json.load(f)
reader = XDMFReader(FileNames=[os.path.join(out, "cell.xdmf")])
reader.UpdatePipeline()
data = servermanager.Fetch(reader)
points, cells = data.GetNumberOfPoints(), data.GetNumberOfCells()
arrays = {data.GetPointData().GetArrayName(k) for k in range(data.GetPointData().GetNumberOfArrays())}
# a panel's (fine) cell has 4 yarns of `cell_fibres_per_yarn` fibres (a hybrid panel's
# coarse yarns have fewer, so the panel's average is not the cell's); a 3-D weave's report
# counts its fibres
fibres = 4 * report["cell_fibres_per_yarn"] if "panel" in report else report["fibres"]
if points == 0 or cells != points - fibres or not {"fibre", "direction"} <= arrays:
    sys.exit(f"cell.xdmf: {points} points, {cells} segments for {fibres} fibres, arrays {sorted(arrays)}")
bounds = data.GetBounds()
thickness = bounds[5] - bounds[4]
if not 0.0 < thickness < report["cell"]["thickness_m"]:
    sys.exit(f"node-centre thickness {thickness} against the reported {report['cell']['thickness_m']}")
view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [800, 600]
display = Show(reader, view)
three_d = "panel" not in report
ColorBy(display, ("POINTS", "role" if three_d else "direction"))
display.LineWidth = 3.0
# from above and to the side; a plain weave's crimp exaggerated 4 times
display.Scale = [1.0, 1.0, 1.0 if three_d else 4.0]
view.CameraPosition = [-1.5, -2.5, 1.2]
view.CameraFocalPoint = [0.0, 0.0, 0.0]
view.CameraViewUp = [0.0, 0.0, 1.0]
view.ResetCamera()
Render(view)
SaveScreenshot(image, view, ImageResolution=[800, 600])
if not os.path.exists(image) or os.path.getsize(image) == 0:
    sys.exit(f"no image written to {image}")
print(f"paraview: relaxed cell of {fibres} fibres, {points} nodes, {cells} segments, "
      f"{1e6 * thickness:.1f} um between node centres; image {image}")

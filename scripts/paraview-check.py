#!/usr/bin/python3
"""Opens a run's fields.xdmf and projectile.xdmf in ParaView (Debian's paraview, headless),
checks their time steps and arrays, and renders the last snapshot to a PNG. Run under
xvfb-run:

    xvfb-run -a /usr/bin/python3 scripts/paraview-check.py OUT [IMAGE.png]

Exits non-zero with a message when something is missing.
"""
import os
import sys

from paraview.simple import (ColorBy, GetActiveViewOrCreate, GetAnimationScene, MergeBlocks, Render, SaveScreenshot,
                             Show, XDMFReader)
from paraview import servermanager

out = sys.argv[1]
image = sys.argv[2] if len(sys.argv) > 2 else os.path.join(out, "fields.png")
reader = XDMFReader(FileNames=[os.path.join(out, "fields.xdmf")])
reader.UpdatePipelineInformation()
times = list(reader.TimestepValues) if reader.TimestepValues else []
if len(times) < 2:
    sys.exit(f"expected several time steps in {out}/fields.xdmf, found {times}")
# the ranks' parts of a snapshot come as blocks: merged, they are the whole fabric
merged = MergeBlocks(Input=reader)
merged.UpdatePipeline(times[-1])
data = servermanager.Fetch(merged)
points = data.GetNumberOfPoints()
cells = data.GetNumberOfCells()
point_arrays = {data.GetPointData().GetArrayName(k) for k in range(data.GetPointData().GetNumberOfArrays())}
cell_arrays = {data.GetCellData().GetArrayName(k) for k in range(data.GetCellData().GetNumberOfArrays())}
missing = {"velocity", "gid", "layer", "yarn", "rank"} - point_arrays | {"strain", "stress", "failure"} - cell_arrays
if points == 0 or cells == 0 or missing:
    sys.exit(f"last snapshot: {points} points, {cells} cells, missing arrays {sorted(missing)}")
view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [800, 600]
display = Show(reader, view)
ColorBy(display, ("CELLS", "stress"))
# the projectile's surface, a triangle mesh per snapshot, at the fabric's times
projectile = XDMFReader(FileNames=[os.path.join(out, "projectile.xdmf")])
projectile.UpdatePipelineInformation()
projectile_times = list(projectile.TimestepValues) if projectile.TimestepValues else []
if projectile_times != times:
    sys.exit(f"projectile.xdmf has times {projectile_times}, fields.xdmf {times}")
projectile.UpdatePipeline(times[-1])
surface = servermanager.Fetch(projectile)
if surface.GetNumberOfPoints() == 0 or surface.GetNumberOfCells() == 0:
    sys.exit("the projectile's surface is empty")
Show(projectile, view)
GetAnimationScene().AnimationTime = times[-1]
view.ResetCamera()
Render(view)
SaveScreenshot(image, view, ImageResolution=[800, 600])
if not os.path.exists(image) or os.path.getsize(image) == 0:
    sys.exit(f"no image written to {image}")
print(f"paraview: {len(times)} time steps, last at {times[-1]:.3e} s: {points} points, {cells} cells, "
      f"point arrays {sorted(point_arrays)}, cell arrays {sorted(cell_arrays)}; projectile {surface.GetNumberOfCells()} triangles; "
      f"image {image}")

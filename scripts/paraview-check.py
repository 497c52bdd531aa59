#!/usr/bin/python3
"""Opens a run's fields.xdmf, broken-elements.xdmf and projectile.xdmf in ParaView (Debian's
paraview, headless), checks their time steps and that every field docs/output.md names is
there, that fields.xdmf draws no broken element (and broken-elements.xdmf nothing else), and
renders the last snapshot, coloured by displacement, to a PNG. Without a display it runs
on its own Xvfb (scripts/virtual_display.py):

    /usr/bin/python3 scripts/paraview-check.py OUT [IMAGE.png]

Exits non-zero with a message when something is missing.
"""
import os
import re
import sys

from virtual_display import ensure_display

ensure_display()  # before ParaView looks for a display
from paraview.simple import (ColorBy, GetActiveViewOrCreate, GetColorTransferFunction, GetAnimationScene, MergeBlocks, Render, SaveScreenshot,
                             Show, XDMFReader)
from paraview import servermanager

out = sys.argv[1]
image = sys.argv[2] if len(sys.argv) > 2 else os.path.join(out, "fields.png")


def documented_fields():
    """The snapshot datasets docs/output.md's table names, less those the XDMF uses as the
    grid itself (step, time, position, connectivity) and the broken subgroup's."""
    docs = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs", "output.md")
    text = open(docs).read()
    table = text.split("## Field snapshots", 1)[1].split("\n\n", 2)[1]
    names = set()
    for row in table.splitlines()[2:]:
        first = row.split("|")[1]
        names.update(n for n in re.findall(r"`([a-z_]+)`", first))
    return names - {"step", "time", "position", "connectivity"}


def last_snapshot(file_name, times):
    """The merged blocks of `file_name` at the last time, and its point and cell arrays."""
    reader = XDMFReader(FileNames=[os.path.join(out, file_name)])
    reader.UpdatePipelineInformation()
    # the ranks' parts of a snapshot come as blocks: merged, they are the whole fabric
    merged = MergeBlocks(Input=reader)
    merged.UpdatePipeline(times[-1])
    data = servermanager.Fetch(merged)
    arrays = lambda fields: {fields.GetArrayName(k): fields.GetArray(k) for k in range(fields.GetNumberOfArrays())}
    return reader, data, arrays(data.GetPointData()), arrays(data.GetCellData())


reader = XDMFReader(FileNames=[os.path.join(out, "fields.xdmf")])
reader.UpdatePipelineInformation()
times = list(reader.TimestepValues) if reader.TimestepValues else []
if len(times) < 2:
    sys.exit(f"expected several time steps in {out}/fields.xdmf, found {times}")
reader, data, point_arrays, cell_arrays = last_snapshot("fields.xdmf", times)
points = data.GetNumberOfPoints()
cells = data.GetNumberOfCells()
missing = documented_fields() - set(point_arrays) - set(cell_arrays)
if points == 0 or cells == 0 or missing:
    sys.exit(f"last snapshot: {points} points, {cells} cells, missing arrays {sorted(missing)} (docs/output.md names them)")
# the picture a user opens draws no broken element (a spike across the panel)
failure_range = cell_arrays["failure"].GetRange()
if failure_range[1] != 0:
    sys.exit(f"fields.xdmf draws broken elements: failure ranges over {failure_range}")
_, broken, _, broken_arrays = last_snapshot("broken-elements.xdmf", times)
broken_cells = broken.GetNumberOfCells()
if broken_cells and broken_arrays["failure"].GetRange()[0] == 0:
    sys.exit("broken-elements.xdmf draws an intact element")
view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [800, 600]
display = Show(reader, view)
ColorBy(display, ("POINTS", "displacement", "Magnitude"))
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
# the colours span the last snapshot's displacements (the first one's are all zero)
GetColorTransferFunction("displacement").RescaleTransferFunction(*point_arrays["displacement"].GetRange(-1))
display.SetScalarBarVisibility(view, True)
# from above and to the side, so the cone behind the impact shows
view.CameraPosition = [1.0, -2.0, 1.5]
view.CameraFocalPoint = [0.0, 0.0, 0.0]
view.CameraViewUp = [0.0, 0.0, 1.0]
view.ResetCamera()
Render(view)
SaveScreenshot(image, view, ImageResolution=[800, 600])
if not os.path.exists(image) or os.path.getsize(image) == 0:
    sys.exit(f"no image written to {image}")
print(f"paraview: {len(times)} time steps, last at {times[-1]:.3e} s: {points} points, {cells} intact and "
      f"{broken_cells} broken cells, "
      f"point arrays {sorted(point_arrays)}, cell arrays {sorted(cell_arrays)}; projectile {surface.GetNumberOfCells()} triangles; "
      f"image {image}")

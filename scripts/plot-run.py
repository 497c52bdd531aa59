#!/usr/bin/python3
"""Plots of one run (h5py, matplotlib): projectile velocity along the line of flight and
contact force; the projectile's energy and, apart, the fabric's by kind; the energy each
layer took with its broken elements; the back-face deflection; and the final state seen from
the side (a slice through the impact plane, intact elements, the projectile's outline).

    /usr/bin/python3 scripts/plot-run.py OUT        # writes OUT/plots/*.png
"""
import json
import math
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

out = sys.argv[1]
plots = os.path.join(out, "plots")
os.makedirs(plots, exist_ok=True)
results = h5py.File(os.path.join(out, "results.h5"), "r")
summary = json.load(open(os.path.join(out, "summary.json")))
time_us = results["history/time"][()] * 1e6
written = []


def save(figure, name):
    path = os.path.join(plots, name)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
    written.append(path)


case = json.loads(results.attrs["case"])
obliquity = math.radians((case.get("projectile") or {}).get("obliquity_deg", 0.0) or 0.0)
# the line of flight at time zero: down the panel's normal, turned about y by the obliquity
flight = (-math.sin(obliquity), 0.0, -math.cos(obliquity))

figure, (speed, force) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
velocity = results["history/projectile_velocity"][()]
speed.plot(time_us, velocity @ flight)
speed.set_ylabel("projectile velocity\nalong the line of flight [m/s]")
force.plot(time_us, (results["history/projectile_force"][()] ** 2).sum(axis=1) ** 0.5)
force.set_ylabel("contact force on the projectile [N]")
force.set_xlabel("time [µs]")
# a residual velocity only for a perforation; otherwise the state and the velocity at the end
outcome = summary.get("outcome", "perforated" if summary["perforated"] else "undecided")
words = "residual" if outcome == "perforated" else f"{outcome}, at end time"
speed.set_title(f"{summary['case']}: {words} {summary['residual_velocity_m_s']:.1f} m/s along the line of flight",
                fontsize=10)
save(figure, "projectile.png")

# energies: the projectile's (which would swamp the rest) above, the fabric's by kind below
figure, (projectile_axes, fabric_axes) = plt.subplots(2, 1, sharex=True, figsize=(7, 7),
                                                      gridspec_kw={"height_ratios": [1, 2]})
energy = results["history/energy"]
projectile_kinetic = energy["projectile_kinetic"][()] + energy["projectile_strain"][()]
projectile_axes.plot(time_us, projectile_kinetic, label="projectile (kinetic + strain)")
projectile_axes.plot(time_us, energy["total"][()], label="total (the balance)", linestyle="--")
projectile_axes.set_ylabel("energy [J]")
projectile_axes.legend(fontsize=8)
fabric_kinds = ["fibre_kinetic", "axial", "bending", "contact", "friction_stored", "friction_dissipated",
                "plastic_dissipated", "fracture_released"]
fabric = sum(energy[kind][()] for kind in fabric_kinds)
for kind in fabric_kinds:
    fabric_axes.plot(time_us, energy[kind][()] * 1e3, label=kind.replace("_", " "), linewidth=1)
fabric_axes.plot(time_us, fabric * 1e3, label="fabric total", color="black", linewidth=2)
fabric_axes.set_xlabel("time [µs]")
fabric_axes.set_ylabel("energy in the fabric [mJ]")
fabric_axes.legend(fontsize=8, ncol=2)
projectile_axes.set_title("energy: the projectile's, and what the fabric took, by kind", fontsize=10)
save(figure, "energies.png")

figure, axes = plt.subplots(figsize=(7, 4))
absorbed = summary["energy_absorbed_by_layer_j"]
broken_by_layer = summary.get("broken_elements_by_layer", [])
axes.bar(range(1, len(absorbed) + 1), [e * 1e3 for e in absorbed])
for layer, count in enumerate(broken_by_layer, start=1):
    axes.annotate(f"{count} broken", (layer, absorbed[layer - 1] * 1e3), ha="center", va="bottom", fontsize=8)
axes.set_xticks(range(1, len(absorbed) + 1))
axes.set_xlabel("layer (1 struck first)")
axes.set_ylabel("energy taken at the end [mJ]")
axes.set_title("energy each layer holds or has dissipated, and its broken elements", fontsize=10)
save(figure, "energy_by_layer.png")

if "history/back_face/largest" in results:
    figure, axes = plt.subplots(figsize=(7, 4))
    axes.plot(time_us, results["history/back_face/largest"][()] * 1e3, label="largest")
    axes.plot(time_us, results["history/back_face/at_axis"][()] * 1e3, label="at the impact axis")
    axes.set_xlabel("time [µs]")
    axes.set_ylabel("back-face deflection [mm]")
    axes.set_title("the last layer's deflection along the panel's normal", fontsize=10)
    axes.legend(fontsize=8)
    save(figure, "back_face.png")

# the final state seen from the side: a slice through the impact axis, intact elements only
# (a broken element's two nodes fly apart), and the projectile's outline at the same step
fields = os.path.join(out, "fields")
parts = [h5py.File(os.path.join(fields, name), "r") for name in sorted(os.listdir(fields)) if name.startswith("ranks-")]
last = max(name for part in parts for name in part.keys())
aim_y = results["history/projectile_position"][0, 1]
SLICE_HALF_WIDTH = 1e-3
figure, axes = plt.subplots(figsize=(8, 4))
for part in (p[last] for p in parts if last in p):
    points, cells = part["position"][()], part["connectivity"][()]
    segments = points[cells]
    near = (abs(segments[:, :, 1] - aim_y) < SLICE_HALF_WIDTH).all(axis=1)
    segments = segments[near] * 1e3
    axes.plot(segments[:, :, 0].T, segments[:, :, 2].T, color="tab:blue", linewidth=0.4)
projectile_file = os.path.join(fields, "projectile.h5")
if os.path.exists(projectile_file):
    surface = h5py.File(projectile_file, "r")
    if last in surface:
        vertices = surface[last]["position"][()] * 1e3
        triangles = vertices[surface[last]["triangles"][()]][:, :, [0, 2]]
        axes.add_collection(PolyCollection(triangles, facecolor="0.6", edgecolor="none"))
axes.set_xlabel("x [mm]")
axes.set_ylabel("z [mm]")
axes.set_aspect("equal", adjustable="datalim")
time = parts[0][last]["time"][0] * 1e6 if last in parts[0] else float("nan")
axes.set_title(f"side view at {time:.1f} µs: the fibres within {SLICE_HALF_WIDTH * 1e3:g} mm of the impact plane "
               "(intact elements) and the projectile", fontsize=10)
save(figure, "panel_side.png")

empty = [p for p in written if os.path.getsize(p) == 0]
if empty:
    sys.exit(f"empty images: {empty}")
print("plots:", ", ".join(written))

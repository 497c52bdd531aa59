#!/usr/bin/python3
"""Plots of one run (h5py, matplotlib): projectile velocity and contact force, energy
histories, energy absorbed per layer, and the final panel seen from the side.

    /usr/bin/python3 scripts/plot-run.py OUT        # writes OUT/plots/*.png
"""
import json
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

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


figure, (speed, force) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
velocity = results["history/projectile_velocity"][()]
speed.plot(time_us, -velocity[:, 2])
speed.set_ylabel("projectile velocity along the shot [m/s]")
force.plot(time_us, (results["history/projectile_force"][()] ** 2).sum(axis=1) ** 0.5)
force.set_ylabel("contact force on the projectile [N]")
force.set_xlabel("time [µs]")
# a residual velocity only for a perforation; otherwise the state and the velocity at the end
outcome = summary.get("outcome", "perforated" if summary["perforated"] else "undecided")
words = "residual" if outcome == "perforated" else f"{outcome}, at end time"
speed.set_title(f"{summary['case']}: {words} {summary['residual_velocity_m_s']:.1f} m/s along the line of flight")
save(figure, "projectile.png")

figure, axes = plt.subplots(figsize=(7, 5))
energy = results["history/energy"]
for kind in ["projectile_kinetic", "projectile_strain", "fibre_kinetic", "axial", "bending", "contact", "friction_dissipated", "plastic_dissipated",
             "fracture_released", "total"]:
    axes.plot(time_us, energy[kind][()] * 1e3, label=kind.replace("_", " "), linewidth=2 if kind == "total" else 1)
axes.set_xlabel("time [µs]")
axes.set_ylabel("energy [mJ]")
axes.legend(fontsize=8)
save(figure, "energies.png")

figure, axes = plt.subplots(figsize=(7, 4))
absorbed = summary["energy_absorbed_by_layer_j"]
axes.bar(range(1, len(absorbed) + 1), [e * 1e3 for e in absorbed])
axes.set_xlabel("layer (1 struck first)")
axes.set_ylabel("energy absorbed [mJ]")
save(figure, "energy_by_layer.png")

# the final state: the last snapshot, one part per rank (the far end of a crossing element
# appears in two parts; plotting it twice is harmless)
parts = [h5py.File(os.path.join(out, "fields", name), "r") for name in sorted(os.listdir(os.path.join(out, "fields"))) if name.startswith("ranks-")]
last = max(name for part in parts for name in part.keys())
position = [part[last]["position"][()] for part in parts if last in part]
failure = [part[last]["failure"][()] for part in parts if last in part]
connectivity = [part[last]["connectivity"][()] for part in parts if last in part]
figure, axes = plt.subplots(figsize=(8, 4))
for points, cells, broken in zip(position, connectivity, failure):
    for colour, selection in (("tab:blue", broken == 0), ("tab:red", broken > 0)):
        segments = points[cells[selection]] * 1e3
        axes.plot(segments[:, :, 0].T, segments[:, :, 2].T, color=colour, linewidth=0.3)
axes.set_xlabel("x [mm]")
axes.set_ylabel("z [mm]")
axes.set_aspect("equal", adjustable="datalim")
axes.set_title(f"final state, {last} (red: broken elements)")
save(figure, "panel_side.png")

empty = [p for p in written if os.path.getsize(p) == 0]
if empty:
    sys.exit(f"empty images: {empty}")
print("plots:", ", ".join(written))

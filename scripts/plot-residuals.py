#!/usr/bin/python3
"""Residual against striking velocity for the validation set's FSP shots on the 3 in panel,
one plot per layer count, from validation/summary.json and each campaign's v50.json only.

    /usr/bin/python3 scripts/plot-residuals.py [--out docs/img/validation-residuals.png]

Every shot of the layer series (`series` "layers"), of the 3 in panel-size bisection and of
the layer series' twins on other meshes (`mesh-layers-*`) is a marker: filled at its
residual velocity when it perforated, hollow below the axis when the fabric stopped it (the
count beside it when several were stopped at one speed; each campaign's stopped shots on a
row of their own just below the axis), a cross at its speed then when the end time came
before either. A campaign's Lambert–Jonas fit
(`vr = a (vs^p - v_bl^p)^(1/p)`, dea-ballistic's `lambert_jonas`, as `dea-mpi v50` wrote it)
is its dashed curve. The mesh series' shot on the layer series' own mesh at 400 m/s is drawn
for scale, and the line vr = vs is what a panel that took nothing would leave.
"""
import argparse
import json
import os
from collections import Counter

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import validation  # noqa: E402  (scripts/validation.py: the root and the summary's place)

ROOT = validation.ROOT
SIDE_M = 0.0762
# the mesh series' shot on the layer series' mesh (4 fibres per yarn within 6 mm, l0/d 0.5)
MESH_REFERENCE = "mesh-3in-4-fibres-6mm-l0-0.5"
# the stopped shots of the k-th campaign are drawn at -(k + 1) times this [m/s]
STOPPED_ROW_M_S = 8.0


def lambert_jonas(striking, fit):
    """The residual velocity [m/s] a Lambert–Jonas fit {v_bl, a, p} gives at `striking`."""
    if striking <= fit["v_bl"]:
        return 0.0
    return fit["a"] * (striking ** fit["p"] - fit["v_bl"] ** fit["p"]) ** (1.0 / fit["p"])


def fit_of(name):
    """The campaign's Lambert–Jonas fit from its v50.json, or None (no file, or no fit)."""
    path = os.path.join(ROOT, "validation", name, "v50.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        fit = json.load(f).get("lambert_jonas")
    return fit.get("Ok") if isinstance(fit, dict) else None


def drawn(entry):
    """Whether a summary entry's shots belong on these plots."""
    on_panel = entry["projectile"] == "fsp_17_grain" and abs(entry["side_m"] - SIDE_M) < 1e-6
    kind = entry["series"] in ("layers", "panel_size") or entry["name"].startswith("mesh-layers-")
    # a pooled entry's shots are its campaigns' own, drawn with them
    return on_panel and kind and bool(entry.get("shot_records")) and not entry.get("pooled_from")


parser = argparse.ArgumentParser()
parser.add_argument("--out", default=os.path.join(ROOT, "docs", "img", "validation-residuals.png"))
args = parser.parse_args()
with open(os.path.join(ROOT, "validation", "summary.json")) as f:
    entries = json.load(f)

chosen = [e for e in entries if drawn(e)]
layer_counts = sorted({e["layers"] for e in chosen})
if not layer_counts:
    raise SystemExit("plot-residuals: no 3 in FSP shots in validation/summary.json yet")
figure, axes_list = plt.subplots(1, len(layer_counts), figsize=(5.6 * len(layer_counts), 4.6), squeeze=False)
colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
reference = next((e for e in entries if e["name"] == MESH_REFERENCE), None)
for axes, layers in zip(axes_list[0], layer_counts):
    campaigns = [e for e in chosen if e["layers"] == layers]
    speeds = [r["velocity_m_s"] for e in campaigns for r in e["shot_records"]]
    low, high = min(speeds) - 50.0, max(speeds) + 50.0
    if layers == 4 and reference and reference.get("shot_records"):
        shot = reference["shot_records"][0]
        high = max(high, shot["velocity_m_s"] + 25.0)
        axes.plot([shot["velocity_m_s"]], [shot["residual_velocity_m_s"]], "D", color="grey",
                  label=f"the series' mesh at {shot['velocity_m_s']:.0f} m/s (mesh series)")
    axes.plot([0.0, high], [0.0, high], ":", color="lightgrey", label="vr = vs (nothing taken)")
    for k, entry in enumerate(campaigns):
        colour = colours[k % len(colours)]
        records = entry["shot_records"]
        through = [r for r in records if r["perforated"]]
        # still moving into the panel when the end time came: neither through nor stopped
        undecided = [r for r in records if not r["perforated"] and r["stopped_by"] == "end_time_s"]
        stopped = Counter(r["velocity_m_s"] for r in records
                          if not r["perforated"] and r["stopped_by"] != "end_time_s")
        label = f"{entry['name']} ({len(through)} through, {sum(stopped.values())} stopped" + (
            f", {len(undecided)} undecided)" if undecided else ")")
        # the stopped shots of each campaign on a row of their own just below the axis
        row = -STOPPED_ROW_M_S * (k + 1)
        if through:
            axes.plot([r["velocity_m_s"] for r in through], [r["residual_velocity_m_s"] for r in through],
                      "o", color=colour, label=label)
        axes.plot(list(stopped), [row] * len(stopped), "o", color=colour, mfc="white",
                  label=None if through else label)
        if undecided:
            axes.plot([r["velocity_m_s"] for r in undecided], [r["residual_velocity_m_s"] for r in undecided],
                      "x", color=colour, label=None)
        for speed, count in stopped.items():
            if count > 1:
                axes.annotate(f"{count}", (speed, row), textcoords="offset points", xytext=(5, -3),
                              color=colour, fontsize=8)
        fit = fit_of(entry["name"])
        if fit:
            grid = [fit["v_bl"] + (high - fit["v_bl"]) * i / 100 for i in range(101)]
            axes.plot(grid, [lambert_jonas(v, fit) for v in grid], "--", color=colour, linewidth=1,
                      label=f"Lambert–Jonas: v_bl {fit['v_bl']:.1f}, a {fit['a']:.2f}, p {fit['p']:.1f}")
    experiment = validation.TABLE_6_1_EXPERIMENT.get(layers)
    if experiment:
        axes.axvline(experiment, color="black", linestyle="--", linewidth=0.8,
                     label=f"V50 measured, {layers} layers, 15 in panel (Table 6-1)")
    axes.set_xlim(low, high)
    axes.set_ylim(-STOPPED_ROW_M_S * (len(campaigns) + 1), high)
    axes.axhline(0.0, color="grey", linewidth=0.6)
    axes.set_xlabel("striking velocity [m/s]")
    axes.set_ylabel("residual velocity [m/s]")
    axes.set_title(f"17-grain FSP, {layers} layers, 3 in panel, fixed edges")
    axes.grid(alpha=0.3)
    axes.legend(fontsize=7, loc="upper left")
figure.text(0.01, 0.01, "filled: perforated, at its residual velocity; hollow, below the axis "
            "(a row per campaign): stopped, with the number of shots stopped at that speed beside it; "
            "x: undecided at the end time, at its speed then", fontsize=7)
figure.tight_layout(rect=(0, 0.03, 1, 1))
os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
figure.savefig(args.out, dpi=110)
print(f"wrote {args.out}")

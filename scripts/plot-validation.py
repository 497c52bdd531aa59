#!/usr/bin/python3
"""The validation set's V50s beside the seed's Table 6-1, from validation/summary.json only.

    /usr/bin/python3 scripts/plot-validation.py [--out docs/img/validation-v50.png]

Left: V50 (bracket or interval as an error bar) of the 4-layer panels against their side,
with the experiment's 245 m/s and the seed's modified DEA 305 m/s for 4 layers of a
15 in panel (markers at its 12 in free span, lines across); a campaign whose every shot so far perforated is drawn as an upper bound (a
hollow downward triangle at its slowest shot, an arrow beneath), one whose every shot was
stopped as a lower bound (an upward triangle at its fastest, an arrow above). Right: V50 against layers beside Table 6-1 (experiment and modified DEA), coloured by the failure model (tension measure and rest law) each series ran under, from
the layer series where it has results; a finer series about a first one's limit is drawn
pooled with it (validation.py's `pooled_from`), not alone; a mesh series' V50 (another fibre
count, element length or stepping on a layer series' panel) stands to the right of its layer
count. A campaign without a V50 yet is listed under the plot with its state, not drawn.
Residual velocities of the mesh series at one speed are printed, not plotted.
"""
import argparse
import json
import os
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import validation  # noqa: E402  (scripts/validation.py: the seed's tables, kept once)

ROOT = validation.ROOT
TABLE_6_1_LAYERS = sorted(validation.TABLE_6_1_EXPERIMENT)
TABLE_6_1_EXPERIMENT = [validation.TABLE_6_1_EXPERIMENT[n] for n in TABLE_6_1_LAYERS]
TABLE_6_1_MODIFIED_DEA = [validation.TABLE_6_1_MODIFIED_DEA[n] for n in TABLE_6_1_LAYERS]

parser = argparse.ArgumentParser()
parser.add_argument("--out", default=os.path.join(ROOT, "docs", "img", "validation-v50.png"))
args = parser.parse_args()
with open(os.path.join(ROOT, "validation", "summary.json")) as f:
    entries = json.load(f)

figure, (size_axes, layer_axes) = plt.subplots(1, 2, figsize=(12.0, 7.5))
pending = []


def bar(axes, x, entry, colour, label):
    """A V50 with its bracket or interval; hollow when the bracket's low end is a shot that was
    still undecided at its end time (scripts/validation.py says so in `method`)."""
    v, low, high = entry["v50_m_s"], entry["v50_low_m_s"], entry["v50_high_m_s"]
    axes.errorbar([x], [v], yerr=[[v - low], [high - v]], fmt="o", color=colour, capsize=5,
                  mfc="white" if undecided(entry) else colour, linestyle="none", label=label)


def undecided(entry):
    return entry.get("v50_low_established") is False


def draw(axes, chosen, x, label, colour=lambda e: "tab:blue"):
    """Draws the entries that have a V50 (each kind of marker labelled once), and a bound for
    those whose every shot so far went one way; lists the others; whether any was drawn."""
    labelled = set()
    for e in chosen:
        if e["v50_m_s"] is None:
            shots = e.get("shot_records") or []
            # every shot so far went through: the V50 lies below the slowest of them, drawn as
            # an upper bound (a downward triangle at that speed, an arrow beneath);
            # validation.py's reading counts shots a low-end campaign fired again
            slowest = e.get("v50_below_m_s")
            if slowest is None and shots and all(r["perforated"] for r in shots):
                slowest = min(r["velocity_m_s"] for r in shots)
            # every shot so far was stopped, none of them only held at its end time: the V50
            # lies above the fastest, drawn as a lower bound (an upward triangle, an arrow above)
            fastest = e.get("v50_above_m_s")
            if fastest is None and shots and all(not r["perforated"] and r["stopped_by"] != "end_time_s" for r in shots):
                fastest = max(r["velocity_m_s"] for r in shots)
            # named by campaign: on the layer axes several series may stand as bounds at once
            for bound, marker, direction, text in (
                    (slowest, "v", -1.0, f"dea-mpi, {e['name']}: every shot perforated, V50 below the slowest"),
                    (fastest, "^", 1.0, f"dea-mpi, {e['name']}: every shot stopped, V50 above the fastest")):
                if bound is None:
                    continue
                axes.plot([x(e)], [bound], marker, color=colour(e), mfc="white", linestyle="none",
                          label=None if text in labelled else text)
                axes.annotate("", xy=(x(e), bound + direction * 45.0), xytext=(x(e), bound),
                              arrowprops=dict(arrowstyle="->", color=colour(e)))
                labelled.add(text)
            pending.append(f"{e['name']}: {e['shots']} shot(s), {e['method'] or 'not started'}")
            continue
        text = label(e) + (" (hollow: low end undecided)" if undecided(e) else "")
        bar(axes, x(e), e, colour(e), None if text in labelled else text)
        labelled.add(text)
    return bool(labelled)


panels = sorted((e for e in entries if e["series"] == "panel_size"), key=lambda e: e["side_m"])


def uniform(e):
    # a panel of the fine fibre count throughout (no coarse yarns, so no layer gap where the
    # shot strikes) beside the hybrid of the same size: drawn a little to its right
    return e.get("coarse_fibres_per_yarn") is None


draw(size_axes, panels, lambda e: 1000 * e["side_m"] * (1.08 if uniform(e) else 1.0),
     lambda e: (f"dea-mpi, 4 layers, {e['fibres_per_yarn']} fibres per yarn throughout (bisection bracket)"
                if uniform(e) else "dea-mpi, 4 layers (bisection bracket)"),
     lambda e: "tab:cyan" if uniform(e) else "tab:blue")
# the seed's panels are 15 in, clamped on a 12 in opening: the markers stand at that free span,
# the lines carry the values across for comparison with the smaller panels run here
SEED_FREE_SPAN_MM = 12 * 25.4
FOUR_LAYERS_EXPERIMENT = validation.TABLE_6_1_EXPERIMENT[4]
FOUR_LAYERS_MODIFIED_DEA = validation.TABLE_6_1_MODIFIED_DEA[4]
size_axes.axhline(FOUR_LAYERS_EXPERIMENT, color="black", linestyle="--")
size_axes.axhline(FOUR_LAYERS_MODIFIED_DEA, color="tab:red", linestyle=":")
size_axes.plot([SEED_FREE_SPAN_MM], [FOUR_LAYERS_EXPERIMENT], "ks--",
               label="experiment, 4 layers, 15 in panel on a 12 in opening (Table 6-1)")
size_axes.plot([SEED_FREE_SPAN_MM], [FOUR_LAYERS_MODIFIED_DEA], "r^:",
               label="seed modified DEA, 4 layers, the same panel (Table 6-1)")
size_axes.set_xscale("log")
size_axes.set_xlabel("panel side [mm] (fixed edges)")
size_axes.set_ylabel("V50 [m/s]")
size_axes.set_title("17-grain FSP, 4 layers of KM2 706: V50 against panel size")
size_axes.set_xlim(7, 420)
size_axes.set_ylim(0, 450)
size_axes.grid(alpha=0.3)
size_axes.legend(fontsize=7, loc="upper left")

layer_axes.plot(TABLE_6_1_LAYERS, TABLE_6_1_EXPERIMENT, "ks--", label="experiment (Table 6-1)")
layer_axes.plot(TABLE_6_1_LAYERS, TABLE_6_1_MODIFIED_DEA, "r^:", label="seed modified DEA (Table 6-1)")
# a finer series is drawn pooled with the one it refines (its shots alone are a part of that)
refining = {name for e in entries if e.get("pooled_from") for name in e["pooled_from"][1:]}
layers = sorted((e for e in entries if e["series"] == "layers" and e["name"] not in refining),
                key=lambda e: (e["layers"], e["name"]))
# several campaigns of one layer count (a finer step about the first one's limit) side by side,
# 0.6 layers apart, each labelled with its campaign
# (a campaign without shots is only listed below the plot, and takes no place)
alongside = {e["name"]: [o["name"] for o in layers if o["layers"] == e["layers"] and o["shots"]] for e in layers}


def layer_position(e):
    same = alongside[e["name"]]
    if e["name"] not in same:
        return e["layers"]
    return e["layers"] + 0.6 * (same.index(e["name"]) - 0.5 * (len(same) - 1))


def estimate_words(method):
    """What the error bar is, from the start of validation.py's `method`."""
    if "around those that mix" in (method or ""):
        return ("MIL-STD-662F" if method.startswith("MIL-STD") else "midpoint") + " about its mixed results, no interval"
    for start, words in (("MIL-STD", "MIL-STD-662F in its bracket, no mixed zone"),
                         ("bracket", "bracket and its midpoint, no mixed zone"),
                         ("logistic maximum likelihood", "logistic, 95 %"),
                         ("Firth's penalised logistic", "Firth's penalised logistic, 95 %")):
        if (method or "").startswith(start):
            return words
    raise ValueError(f"a layer series' V50 of an unknown kind: {method!r}")


MODEL_WORDS = {("element", "cone"): "the seed's element measure",
               ("gauge", "cone"): "tension gauge",
               ("gauge", "smooth"): "tension gauge + smooth rest law (defaults)"}


def layer_label(e):
    # named always: one label per campaign, so that a lone campaign of its layer count is not
    # read as the legend of every point; the model is said in words beside its colour
    model = MODEL_WORDS.get((e.get("tension_measure"), e.get("rest_angle_law")),
                            f"{e.get('tension_measure')} measure, {e.get('rest_angle_law')} rest law")
    # the panel is said once, in the title: every layer series here is the 3 in panel
    return f"{e['name']}: {model} ({estimate_words(e['method'])})"


# coloured by the failure model a series ran under, so that the series of one model read as
# one curve against layers: the seed's literal element measure and cone rest law, the tension
# gauge alone, and the two defaults since 2026-12-03 (theory I9c, I9d)
MODEL_COLOURS = {("element", "cone"): "tab:blue", ("gauge", "cone"): "tab:purple",
                 ("gauge", "smooth"): "tab:green"}


def model_colour(e):
    return MODEL_COLOURS.get((e.get("tension_measure"), e.get("rest_angle_law")), "tab:gray")


if not draw(layer_axes, layers, layer_position, layer_label, model_colour):
    layer_axes.text(0.5, 0.08, "no layer series has a V50 yet", transform=layer_axes.transAxes, ha="center", fontsize=8)
# the mesh series' limits beside the layer series' (to the right of their layer count): how far
# the fibre count, the coarse element length or multi-rate stepping move the V50
# (a mesh-layers series whose every shot so far went one way stands as its bound; the mesh
# series at one striking speed are residual velocities, printed below, not limits)
meshes = sorted((e for e in entries if e["series"] == "mesh" and e["name"] not in refining
                 and (e["v50_m_s"] is not None or (e["name"].startswith("mesh-layers-") and e["shots"]))),
                key=lambda e: e["name"])


def mesh_label(e):
    # the fibre count, and what else differs from the layer series' mesh on the same panel
    reference = next((o for o in layers if (o["layers"], o["side_m"]) == (e["layers"], e["side_m"])), {})
    words = [f"{e['fibres_per_yarn']} fibres per yarn"]
    if e["fine_radius_m"] != reference.get("fine_radius_m"):
        words.append(f"within {1000 * e['fine_radius_m']:.0f} mm")
    if e["element_length_ratio"] != reference.get("element_length_ratio"):
        words.append(f"l0/d {e['element_length_ratio']:g}")
    if e.get("coarse_element_length_ratio") not in (None, e["element_length_ratio"]):
        words.append(f"coarse l0/d {e['coarse_element_length_ratio']:g}")
    if e.get("multi_rate"):
        words.append("multi-rate")
    if e.get("pooled_from"):
        # a pooled entry shares its first campaign's mesh: without this its label repeats that
        # campaign's and the legend would show only one of the two points
        words.append(f"{len(e['pooled_from'])} series pooled")
    return f"{1000 * e['side_m']:.0f} mm panel, {', '.join(words)} ({estimate_words(e['method'])})"


MESH_COLOURS = ("tab:orange", "tab:brown", "tab:pink", "tab:olive")
draw(layer_axes, meshes, lambda e: e["layers"] + 1.0 + 0.6 * meshes.index(e), mesh_label,
     lambda e: MESH_COLOURS[meshes.index(e) % len(MESH_COLOURS)])
layer_axes.set_xlabel("layers")
layer_axes.set_ylabel("V50 [m/s]")
sides = sorted({e["side_m"] for e in layers + meshes})
layer_axes.set_title("V50 against layers; dea-mpi on "
                     + ", ".join(f"{1000 * side:.0f} mm" for side in sides) + " panels")
layer_axes.set_xlim(0, 30)
layer_axes.set_ylim(0, 700)
layer_axes.grid(alpha=0.3)
# below the axes, ending at their right edge and reaching left under the panel-size axes:
# the layer series sit low at 4 and 8 layers, where a legend inside would hide them
layer_axes.legend(fontsize=7, loc="upper right", bbox_to_anchor=(1.0, -0.10))
# wrapped here rather than by matplotlib, whose wrap ran past the figure's right edge; the
# axes give up as much height as the lines take
footnote = textwrap.wrap("not yet decided: " + "; ".join(pending), width=250) if pending else []
if footnote:
    figure.text(0.01, 0.01, "\n".join(footnote), fontsize=6, va="bottom")
figure.tight_layout(rect=(0, 0.015 + 0.013 * len(footnote), 1, 1))
figure.savefig(args.out, dpi=130)
print(args.out)
for e in (e for e in entries if e["series"] == "mesh"):
    shots = ", ".join(f"{r['velocity_m_s']:.0f} m/s -> {r['residual_velocity_m_s']:.1f} m/s ({r['stopped_by']})" for r in e["shot_records"])
    print(f"{e['name']}: {shots or 'not run'}")

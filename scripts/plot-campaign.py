#!/usr/bin/python3
"""The probability of perforation against striking velocity of one V50 campaign, with its shots.

    /usr/bin/python3 scripts/plot-campaign.py OUT [--title TEXT]

Reads OUT/v50.json (written by `dea-mpi v50`) and writes OUT/v50.png: each shot at 1
(complete) or 0 (partial; hollow when it was still undecided at the end time), the logistic
and probit curves where a fit exists, V50 with its 95 % interval (delta method) and V10, V90.
When maximum likelihood has no curve (the shots separate by velocity), the plot says why (the
report's reason) and draws Firth's penalised logistic instead (docs/theory.md V11), dashed, with
its profile interval where that lies within the plot.
"""
import argparse
import json
import math
import os
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("out")
parser.add_argument("--title")
args = parser.parse_args()
with open(os.path.join(args.out, "v50.json")) as f:
    report = json.load(f)
shots = report["shots"]
if not shots:
    raise SystemExit(f"{args.out}/v50.json: no shots on record")

figure, axes = plt.subplots(figsize=(7.0, 4.2))
velocities = [s["velocity_m_s"] for s in shots]
low, high = min(velocities), max(velocities)
pad = 0.15 * (high - low) + 5.0
grid = [low - pad + (high - low + 2 * pad) * k / 400 for k in range(401)]


def logistic(z):
    return 1.0 / (1.0 + math.exp(-z))


def normal(z):
    return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))


notes = []
for name, link, colour in (("logistic", logistic, "tab:blue"), ("probit", normal, "tab:green")):
    fit = report[name]
    if "Ok" not in fit:
        notes.append(f"{name}: {fit['Err']}")
        continue
    fit = fit["Ok"]
    axes.plot(grid, [link(fit["intercept"] + fit["slope"] * v) for v in grid], color=colour,
              label=f"{name}: V50 {fit['v50']['velocity']:.0f} m/s "
                    f"({fit['v50']['low']:.0f}..{fit['v50']['high']:.0f}), "
                    f"V10 {fit['v10']['velocity']:.0f}, V90 {fit['v90']['velocity']:.0f}")
    if name == "logistic":
        v50 = fit["v50"]
        axes.errorbar([v50["velocity"]], [0.5], xerr=[[v50["velocity"] - v50["low"]], [v50["high"] - v50["velocity"]]],
                      fmt="D", color=colour, capsize=4, label="logistic V50, 95 % interval")
firth = report.get("firth_logistic", {})
if "Ok" not in report["logistic"] and "Ok" in firth:
    fit = firth["Ok"]
    v50 = fit["v50"]
    # an unbounded end is null in the JSON
    ends = (v50["profile_low"], v50["profile_high"])
    words = " to ".join("unbounded" if e is None else f"{e:.0f}" for e in ends)
    axes.plot(grid, [logistic(fit["intercept"] + fit["slope"] * v) for v in grid], color="tab:purple", linestyle="--",
              label=f"Firth's penalised logistic: V50 {v50['velocity']:.0f} m/s (95 %: {words}), "
                    f"V10 {fit['v10']['velocity']:.0f}, V90 {fit['v90']['velocity']:.0f}")
    if None not in ends and grid[0] <= ends[0] and ends[1] <= grid[-1]:
        axes.errorbar([v50["velocity"]], [0.5], xerr=[[v50["velocity"] - ends[0]], [ends[1] - v50["velocity"]]],
                      fmt="D", color="tab:purple", capsize=4, label="Firth's V50, 95 % profile interval")
    else:
        notes.append("Firth's interval reaches beyond the plot: too few shots to bound the limit")
for perforated, marker, label in ((True, "^", "complete"), (False, "v", "partial")):
    for held in (False, True):
        chosen = [s for s in shots if s["perforated"] == perforated and (s["stopped_by"] == "end_time_s") == held]
        if not chosen:
            continue
        axes.scatter([s["velocity_m_s"] for s in chosen], [1.0 if perforated else 0.0] * len(chosen), marker=marker,
                     s=45, facecolors="none" if held else ("tab:red" if perforated else "black"),
                     edgecolors="tab:red" if perforated else "black",
                     label=label + (" (undecided at the end time)" if held else ""), zorder=3)
    # shots of one outcome at one speed lie on one another: their number beside them
    same_speed = {}
    for shot in (s for s in shots if s["perforated"] == perforated):
        same_speed[shot["velocity_m_s"]] = same_speed.get(shot["velocity_m_s"], 0) + 1
    for velocity, count in same_speed.items():
        if count > 1:
            axes.annotate(f"×{count}", (velocity, 1.0 if perforated else 0.0), xytext=(4, 5 if perforated else -11),
                          textcoords="offset points", fontsize=7)
axes.set_ylim(-0.08, 1.08)
axes.set_xlabel("striking velocity [m/s]")
axes.set_ylabel("probability of perforation")
axes.set_title(textwrap.fill(args.title or f"{report['campaign']}: {len(shots)} shots "
                                           f"({report['partials']} partial, {report['completes']} complete)", 80),
               fontsize=10)
axes.grid(alpha=0.3)
# above the markers at probability 0, right, where a rising curve leaves room
axes.legend(fontsize=7, loc="lower right", bbox_to_anchor=(1.0, 0.12))
# why a fit is missing: wrapped, below the axes, the figure made taller to hold it
text = "\n".join(textwrap.fill(note, 120) for note in notes)
lines = text.count("\n") + 1 if notes else 0
height = 4.2 + 0.13 * lines
figure.set_size_inches(7.0, height)
below = (0.13 * lines + 0.1) / height if notes else 0.0
figure.tight_layout(rect=(0.0, below, 1.0, 1.0))
if notes:
    figure.text(0.01, 0.02, text, fontsize=7, va="bottom")
path = os.path.join(args.out, "v50.png")
figure.savefig(path, dpi=130)
print(path)

#!/usr/bin/python3
"""The probability of perforation against striking velocity of one V50 campaign, with its shots.

    /usr/bin/python3 scripts/plot-campaign.py OUT [--title TEXT]

Reads OUT/v50.json (written by `dea-mpi v50`) and writes OUT/v50.png: each shot at 1
(complete) or 0 (partial; hollow when it was still undecided at the end time), the logistic
and probit curves where a fit exists, V50 with its 95 % interval (delta method) and V10, V90.
When no curve can be fitted, the plot says why (the report's reason) instead of drawing one.
"""
import argparse
import json
import math
import os

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
for perforated, marker, label in ((True, "^", "complete"), (False, "v", "partial")):
    for held in (False, True):
        chosen = [s for s in shots if s["perforated"] == perforated and (s["stopped_by"] == "end_time_s") == held]
        if not chosen:
            continue
        axes.scatter([s["velocity_m_s"] for s in chosen], [1.0 if perforated else 0.0] * len(chosen), marker=marker,
                     s=45, facecolors="none" if held else ("tab:red" if perforated else "black"),
                     edgecolors="tab:red" if perforated else "black",
                     label=label + (" (undecided at the end time)" if held else ""), zorder=3)
axes.set_ylim(-0.08, 1.08)
axes.set_xlabel("striking velocity [m/s]")
axes.set_ylabel("probability of perforation")
axes.set_title(args.title or f"{report['campaign']}: {len(shots)} shots "
                             f"({report['partials']} partial, {report['completes']} complete)")
axes.grid(alpha=0.3)
if notes:
    axes.text(0.02, 0.55, "\n".join(notes), transform=axes.transAxes, fontsize=7, wrap=True, va="center")
axes.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.0, 0.93))
figure.tight_layout()
path = os.path.join(args.out, "v50.png")
figure.savefig(path, dpi=130)
print(path)

#!/usr/bin/python3
"""The V50 of a layer sweep (jobs/v50-layer-sweep.sh OUTDIR) against the number of layers:
a Markdown table on stdout (logistic V50 with its 95 % interval, probit, Firth's penalised
logistic with its profile interval (docs/theory.md V11), MIL-STD-662F, Lambert-Jonas, shots) and OUTDIR/v50-layers.png with the interval as a band, beside the
seed's Table 6-1 (modified DEA, the I0 and I_inf bounds, and the experiment). Only data that
exists is drawn: a layer count whose shots give no fit is drawn as the bracket its shots
make (highest stop to lowest perforation, an arrow when one side is open), one not run is
named under the plot, and the legend gives the swept panel's side (the seed's panels are
far larger than a test target).

    /usr/bin/python3 scripts/plot-layer-sweep.py OUTDIR [--title TEXT]
"""
import argparse
import glob
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# seed Table 6-1 (PHYSICS.md section 7), m/s
SEED_LAYERS = [1, 4, 8, 12, 16, 20, 24, 28]
SEED_MODIFIED_DEA = [135, 305, 407, 435, 475, 505, 525, 545]
SEED_I0 = [220, 475, 570, 625, 645, 665, 675, 683]
SEED_I_INF = [85, 190, 300, 315, 355, 430, 430, 450]
SEED_EXPERIMENT_LAYERS = [4, 8, 12, 16, 20, 24, 28]
SEED_EXPERIMENT = [245, 287, 416, 441, 511, 506, 549]

parser = argparse.ArgumentParser()
parser.add_argument("out")
parser.add_argument("--title", default="V50 against layers")
args = parser.parse_args()
layers = [int(line) for line in open(os.path.join(args.out, "layers.txt")) if line.strip()]
rows, points, brackets, not_run, sides = [], [], [], [], set()
value = lambda estimate, key: estimate["Ok"][key] if "Ok" in estimate else None
fmt = lambda v: "–" if v is None else f"{v:.1f}"
for count in layers:
    path = os.path.join(args.out, str(count), "v50.json")
    if not os.path.exists(path):
        rows.append(f"| {count} | not run | | | | | | |")
        not_run.append(count)
        continue
    report = json.load(open(path))
    for provenance in glob.glob(os.path.join(args.out, str(count), "shots", "*", "provenance.json")):
        side = ((json.load(open(provenance)).get("case") or {}).get("target") or {}).get("side_m")
        if side:
            sides.add(side)
        break
    logistic = report["logistic"].get("Ok")
    v50 = logistic["v50"] if logistic else None
    probit = value(report["probit"], "v50")
    interval = f"{v50['low']:.1f}–{v50['high']:.1f}" if v50 else "–"
    # Firth's fit exists where the shots separate; an unbounded end of its interval is null
    firth = value(report.get("firth_logistic", {}), "v50")
    firth_words = (f"{firth['velocity']:.1f} (" + " to ".join(unbounded if e is None else f"{e:.1f}" for e, unbounded in
                                                        ((firth["profile_low"], "−∞"), (firth["profile_high"], "∞"))) + ")"
                   if firth else "–")
    rows.append(
        f"| {count} | {fmt(v50 and v50['velocity'])} | {interval} "
        f"| {fmt(probit and probit['velocity'])} | {firth_words} | {fmt(value(report['mil_std_662f'], 'v50'))} | {fmt(value(report['lambert_jonas'], 'v_bl'))} "
        f"| {len(report['shots'])} ({report['partials']} / {report['completes']}) |"
    )
    if v50:
        points.append((count, v50["velocity"], v50["low"], v50["high"]))
    else:
        stopped = [shot["velocity_m_s"] for shot in report["shots"] if not shot["perforated"]]
        perforated = [shot["velocity_m_s"] for shot in report["shots"] if shot["perforated"]]
        brackets.append((count, max(stopped) if stopped else None, min(perforated) if perforated else None))
print("| layers | logistic V50 [m/s] | 95 % interval | probit V50 | Firth V50 (95 % profile) | MIL-STD-662F "
      "| Lambert–Jonas v_bl | shots (partial / complete) |")
print("|---|---|---|---|---|---|---|---|")
print("\n".join(rows))
figure, axes = plt.subplots(figsize=(7, 4.5))
side = ", ".join(f"{s * 1e3:g} mm" for s in sorted(sides)) or "side unknown"
if points:
    x, v, low, high = zip(*points)
    axes.fill_between(x, low, high, alpha=0.3, label=f"this sweep ({side} panel): 95 % interval")
    axes.plot(x, v, "o-", label=f"this sweep ({side} panel): logistic V50")
for k, (count, stopped, perforated) in enumerate(brackets):
    label = f"this sweep ({side} panel): no fit, its shots' bracket" if k == 0 else None
    if stopped is not None and perforated is not None:
        axes.plot([count, count], [stopped, perforated], "_-", color="tab:red", markersize=12, linewidth=2, label=label)
    elif perforated is not None:
        axes.annotate("", (count, perforated - 40), (count, perforated), arrowprops={"arrowstyle": "->", "color": "tab:red"})
        axes.plot([count], [perforated], "_", color="tab:red", markersize=12, label=label)
    elif stopped is not None:
        axes.annotate("", (count, stopped + 40), (count, stopped), arrowprops={"arrowstyle": "->", "color": "tab:red"})
        axes.plot([count], [stopped], "_", color="tab:red", markersize=12, label=label)
if not_run:
    figure.text(0.01, 0.01, f"not run: {', '.join(map(str, not_run))} layers", fontsize=8)
axes.plot(SEED_LAYERS, SEED_MODIFIED_DEA, "s--", label="seed: modified DEA")
axes.plot(SEED_LAYERS, SEED_I0, ":", color="grey", label="seed: I0 / I_inf bounds")
axes.plot(SEED_LAYERS, SEED_I_INF, ":", color="grey")
axes.plot(SEED_EXPERIMENT_LAYERS, SEED_EXPERIMENT, "k^", label="seed: experiment")
axes.set_xlabel("layers")
axes.set_ylabel("V50 [m/s]")
axes.set_title(args.title)
axes.legend(fontsize=8)
figure.tight_layout()
figure.savefig(os.path.join(args.out, "v50-layers.png"), dpi=120)

#!/usr/bin/python3
"""The course of each shot of validation campaigns, from the traces committed beside their
records (`validation/<campaign>/shots/<id>.trace.csv`, written by scripts/validation.py).

    /usr/bin/python3 scripts/plot-traces.py CAMPAIGN [CAMPAIGN ...] [--out docs/img/traces.png]

Top: the projectile's velocity along the shot line (positive into the panel) against time,
one line per shot, labelled with its striking speed and outcome; a stopped shot's line ends
where it turned back. Bottom: the elements broken in each layer, the same colours, one line
style per layer. A shot on record without a trace (fired before traces were kept, on a
machine whose run directory is gone) is named under the plot, not drawn.
"""
import argparse
import csv
import os
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import validation  # noqa: E402  (scripts/validation.py: the results' place and the trace's name)

LAYER_STYLES = ("-", "--", "-.", ":")


def read_trace(path):
    """The trace's columns by name, as floats."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {name: [float(row[k]) for row in body] for k, name in enumerate(header)}


def outcome(record):
    if record["perforated"]:
        return f"through, {record['residual_velocity_m_s']:.1f} m/s left"
    if record["stopped_by"] == "end_time_s":
        return "undecided at the end time"
    return "stopped"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("campaigns", nargs="+", help="validation campaign names (directories of validation/)")
    parser.add_argument("--out", default=os.path.join(validation.ROOT, "docs", "img", "traces.png"))
    args = parser.parse_args()

    figure, (speed_axes, broken_axes) = plt.subplots(2, 1, figsize=(9, 8), sharex=True,
                                                     gridspec_kw={"height_ratios": [3, 2]})
    missing, drawn = [], 0
    for name in args.campaigns:
        if not os.path.isdir(os.path.join(validation.RESULTS, name)):
            raise SystemExit(f"plot-traces: no campaign {name!r} under {validation.RESULTS}")
        for record in validation.records(name):
            path = validation.trace_path(name, record["id"])
            if not os.path.exists(path):
                missing.append(f"{name} {record['id']} ({record['velocity_m_s']:g} m/s)")
                continue
            trace = read_trace(path)
            time_us = [1e6 * t for t in trace["time_s"]]
            label = f"{name} {record['id']}: {record['velocity_m_s']:g} m/s, {outcome(record)}"
            line, = speed_axes.plot(time_us, [-v for v in trace["projectile_velocity_z_m_s"]], label=label)
            layers = sorted(c for c in trace if c.startswith("broken_layer_"))
            for k, column in enumerate(layers):
                broken_axes.plot(time_us, trace[column], color=line.get_color(),
                                 linestyle=LAYER_STYLES[k % len(LAYER_STYLES)],
                                 label=f"layer {column.rsplit('_', 1)[1]}" if drawn == 0 else None)
            drawn += 1
    if drawn == 0:
        raise SystemExit("plot-traces: no shot of " + ", ".join(args.campaigns) + " has a trace")
    speed_axes.axhline(0.0, color="grey", linewidth=0.8)
    speed_axes.set_ylabel("velocity along the shot line [m/s]")
    speed_axes.set_title("The projectile's course, shot by shot (" + ", ".join(args.campaigns) + ")")
    speed_axes.grid(alpha=0.3)
    speed_axes.legend(fontsize=7)
    broken_axes.set_xlabel("time [µs]")
    broken_axes.set_ylabel("elements broken, by layer (0: struck face)")
    broken_axes.grid(alpha=0.3)
    broken_axes.legend(fontsize=7, title="line style", title_fontsize=7)
    # the shots without a trace, wrapped to the figure's width, the axes raised to make room
    note = textwrap.wrap("no trace (fired before traces were kept): " + "; ".join(missing), 190) if missing else []
    if note:
        figure.text(0.01, 0.005, "\n".join(note), fontsize=6, va="bottom")
    figure.tight_layout(rect=(0, 0.005 + 0.012 * len(note), 1, 1))
    figure.savefig(args.out, dpi=110)
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

#!/usr/bin/python3
"""The course of each shot of validation campaigns, from the traces committed beside their
records (`validation/<campaign>/shots/<id>.trace.csv`, written by scripts/validation.py).

    /usr/bin/python3 scripts/plot-traces.py CAMPAIGN [CAMPAIGN ...] [--out docs/img/traces.png]

Top: the projectile's velocity along the shot line (positive into the panel) against time,
one line per shot, labelled with its striking speed and outcome; a stopped shot's line ends
where it turned back. Bottom: the elements broken in each layer. Up to four layers, one
axes: the shots' colours, one line style per layer. More layers than line styles (8 or 12
layers), one small axes per shot, titled in its colour, the layers shaded from the struck
face to the back. A shot on record without a trace (fired before traces were kept, on a
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


layer_columns = validation.layer_columns


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

    shots, missing = [], []
    for name in args.campaigns:
        if not os.path.isdir(os.path.join(validation.RESULTS, name)):
            raise SystemExit(f"plot-traces: no campaign {name!r} under {validation.RESULTS}")
        for record in validation.records(name):
            path = validation.trace_path(name, record["id"])
            if os.path.exists(path):
                shots.append((name, record, read_trace(path)))
            else:
                missing.append(f"{name} {record['id']} ({record['velocity_m_s']:g} m/s)")
    if not shots:
        raise SystemExit("plot-traces: no shot of " + ", ".join(args.campaigns) + " has a trace")
    most_layers = max(len(layer_columns(trace)) for _, _, trace in shots)
    # four line styles tell four layers apart; beyond them one axes a shot, layers shaded
    per_shot = most_layers > len(LAYER_STYLES)
    columns = min(len(shots), 4) if per_shot else 1
    rows = -(-len(shots) // columns) if per_shot else 1
    # constrained layout keeps the colour bar and the small axes apart (tight_layout cannot)
    figure = plt.figure(figsize=(9, 5 + (2.6 * rows if per_shot else 3)), layout="constrained")
    grid = figure.add_gridspec(1 + rows, columns, height_ratios=[3] + [2 if not per_shot else 1.6] * rows)
    speed_axes = figure.add_subplot(grid[0, :])
    shaded = plt.get_cmap("viridis")
    broken_axes = None if per_shot else figure.add_subplot(grid[1, 0], sharex=speed_axes)
    # ten colours repeat from the eleventh shot on; past ten, tab20's dark ten then its light ten
    palette = plt.get_cmap("tab10" if len(shots) <= 10 else "tab20")
    order = list(range(10)) if len(shots) <= 10 else list(range(0, 20, 2)) + list(range(1, 20, 2))
    for n, (name, record, trace) in enumerate(shots):
        time_us = [1e6 * t for t in trace["time_s"]]
        label = f"{name} {record['id']}: {record['velocity_m_s']:g} m/s, {outcome(record)}"
        line, = speed_axes.plot(time_us, [-v for v in trace["projectile_velocity_z_m_s"]], label=label,
                                color=palette(order[n % len(order)]))
        layers = layer_columns(trace)
        if per_shot:
            axes = figure.add_subplot(grid[1 + n // columns, n % columns], sharex=speed_axes)
            for k, column in enumerate(layers):
                axes.plot(time_us, trace[column], linewidth=1.0,
                          color=shaded(k / max(most_layers - 1, 1)))
            axes.set_title(f"{record['id']}: {record['velocity_m_s']:g} m/s", fontsize=8, color=line.get_color())
            axes.tick_params(labelsize=7)
            axes.grid(alpha=0.3)
            if n % columns == 0:
                axes.set_ylabel("elements broken", fontsize=8)
            if n // columns == rows - 1:
                axes.set_xlabel("time [µs]", fontsize=8)
        else:
            for k, column in enumerate(layers):
                broken_axes.plot(time_us, trace[column], color=line.get_color(),
                                 linestyle=LAYER_STYLES[k % len(LAYER_STYLES)],
                                 label=f"layer {column.rsplit('_', 1)[1]}" if n == 0 else None)
    speed_axes.axhline(0.0, color="grey", linewidth=0.8)
    speed_axes.set_ylabel("velocity along the shot line [m/s]")
    # one campaign name per line: two long names on one line ran past the figure's edge
    speed_axes.set_title("The projectile's course, shot by shot\n" + "\n".join(args.campaigns),
                         fontsize=10)
    speed_axes.grid(alpha=0.3)
    speed_axes.legend(fontsize=7)
    if per_shot:
        # one scale for the shading of every small axes: layer 0 the struck face
        scale = matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0, most_layers - 1), cmap=shaded)
        bar = figure.colorbar(scale, ax=figure.axes[1:], shrink=0.9, pad=0.02)
        bar.set_label("layer (0: struck face)", fontsize=8)
        bar.ax.tick_params(labelsize=7)
    else:
        broken_axes.set_xlabel("time [µs]")
        broken_axes.set_ylabel("elements broken, by layer (0: struck face)")
        broken_axes.grid(alpha=0.3)
        broken_axes.legend(fontsize=7, title="line style", title_fontsize=7)
    # the shots without a trace, wrapped to the figure's width, the axes raised to make room
    note = textwrap.wrap("no trace (fired before traces were kept): " + "; ".join(missing), 190) if missing else []
    if note:
        figure.text(0.01, 0.005, "\n".join(note), fontsize=6, va="bottom")
    figure.get_layout_engine().set(rect=(0, 0.005 + 0.012 * len(note), 1, 1 - 0.005 - 0.012 * len(note)))
    figure.savefig(args.out, dpi=110)
    print(args.out)
    return 0

if __name__ == "__main__":
    raise SystemExit(main())

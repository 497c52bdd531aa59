#!/usr/bin/env python3
"""What a shot costs over rank counts: a Markdown table of `dea-mpi check`'s price.

    scripts/cost-model.py [CASE] [--ranks 64,256,1024] [--ranks-per-host 1]

CASE defaults to the 28-layer Table 6-1 panel with its fine disc
(cases/km2_706_28_layer_disc.json). Each row is `dea-mpi check CASE --ranks K
--ranks-per-host M`: the cost model calibrated on the reference shot (docs/theory.md C1) on
the partition `run` would make, steps to the end time after the settle (an upper bound).
With fewer ranks per host than ranks, messages between hosts cross the interconnect the
calibration assumes. There is no second model here: this script only tabulates check's.
"""
import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def figure(value):
    """A price as people read it: whole numbers from 100 on, three figures below."""
    return f"{value:,.0f}" if value >= 100 else f"{value:.3g}"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("case", nargs="?", default=os.path.join(ROOT, "cases", "km2_706_28_layer_disc.json"))
    parser.add_argument("--ranks", default="64,256,1024", help="comma-separated rank counts")
    parser.add_argument("--ranks-per-host", type=int, default=1, help="ranks sharing a host (default 1)")
    parser.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "dea-mpi"))
    args = parser.parse_args()
    try:
        counts = [int(r) for r in args.ranks.split(",")]
    except ValueError:
        sys.exit(f"cost-model: --ranks {args.ranks!r}: expected comma-separated rank counts, like 64,256")
    if not counts or min(counts) < 1 or args.ranks_per_host < 1:
        sys.exit("cost-model: every rank count and --ranks-per-host must be at least 1")
    rows = []
    for ranks in counts:
        command = [args.binary, "check", args.case, "--ranks", str(ranks), "--ranks-per-host", str(min(args.ranks_per_host, ranks))]
        checked = subprocess.run(command, capture_output=True, text=True)
        if checked.returncode != 0:
            sys.stderr.write(checked.stderr)
            sys.exit(checked.returncode)
        resolved = json.loads(checked.stdout)["resolved"]
        rows.append((ranks, resolved))
    first = rows[0][1]
    print(f"{os.path.basename(args.case)}: {first['nodes']:,} nodes, {first['cost']['steps']:,} steps "
          f"(settle {first['cost']['settle_steps']:,}); calibration: {first['cost']['calibration']}\n")
    print("| ranks | ranks per host | largest share (nodes) | partition: work, stored imbalance | step | of it between hosts | slowest / mean | wall per shot | core-hours per shot |")
    print("|---|---|---|---|---|---|---|---|---|")
    for ranks, resolved in rows:
        cost = resolved["cost"]
        print(f"| {ranks} | {cost['ranks_per_host']} | {resolved['memory']['largest_rank_nodes']:,} | {resolved['memory']['work_imbalance']:.3f}, {resolved['memory']['stored_imbalance']:.3f} | {1e3 * cost['step_s']:.1f} ms "
              f"| {1e3 * cost['network_s']:.2f} ms | {cost['imbalance']:.2f} | {figure(cost['wall_s'] / 3600)} h | {figure(cost['core_hours'])} |")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Core-hours a case or a V50 campaign will cost, before it is submitted.

    jobs/cost.py CASE_OR_CAMPAIGN.json [--ranks-per-shot 16] [--ranks-per-host 16] [--tasks 64]

It asks `dea-mpi check --ranks K --ranks-per-host M` for its price: the cost model calibrated
on the reference shot (docs/theory.md C1), on the partition `run` would make of the target
over a shot's K ranks, M of them per host (messages between hosts over the interconnect the
calibration assumes). Steps count to the case's end time after its settle, so a shot that is
decided earlier costs less: an upper bound, for requesting wall time. A campaign's shots are
its design's (a bisection: its halvings of the bounds plus one bound; a sequential design:
times its replicates). The wall time spreads the shots over the groups of K ranks that
--tasks holds, in rounds. What check refuses (a missing file, a bad field, a host too small
for its ranks' shares) is refused here with check's message and exit code.
"""
import argparse
import json
import math
import os
import signal
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def figure(value):
    """A price as people read it: whole numbers from 100 on, three figures below."""
    return f"{value:,.0f}" if value >= 100 else f"{value:.3g}"


def main():
    # output into a closed pipe (| head) ends quietly, as for any Unix tool
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("case", help="a case or a campaign file")
    parser.add_argument("--ranks-per-shot", type=int, default=16, help="ranks of one shot (default 16)")
    parser.add_argument("--ranks-per-host", type=int, help="of them on one host (default: all on one)")
    parser.add_argument("--tasks", type=int, default=64, help="ranks of the whole job (default 64)")
    parser.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "dea-mpi"))
    args = parser.parse_args()
    if args.ranks_per_shot < 1:
        sys.exit(f"cost: --ranks-per-shot must be at least 1, got {args.ranks_per_shot}")
    if args.tasks < args.ranks_per_shot:
        sys.exit(f"cost: --tasks {args.tasks} cannot hold one shot's {args.ranks_per_shot} ranks")
    per_host = args.ranks_per_host or args.ranks_per_shot
    if per_host < 1:
        sys.exit(f"cost: --ranks-per-host must be at least 1, got {per_host}")
    command = [args.binary, "check", args.case, "--ranks", str(args.ranks_per_shot), "--ranks-per-host", str(per_host)]
    try:
        checked = subprocess.run(command, capture_output=True, text=True)
    except OSError as e:
        sys.exit(f"cost: {args.binary}: {e.strerror} (build with scripts/setup.sh)")
    if checked.returncode != 0:
        sys.stderr.write(checked.stderr)
        sys.exit(checked.returncode)
    printed = json.loads(checked.stdout)
    cost = printed["resolved"]["cost"]
    name = (printed.get("campaign") or printed["case"]).get("name", args.case)
    nodes = printed["resolved"]["nodes"]
    print(f"{name}: {nodes:,} nodes, at most {cost['steps']:,} steps per shot "
          f"({cost['settle_steps']:,} of them the settle's)")
    network = f", of it {1e3 * cost['network_s']:.3f} ms between hosts" if cost["network_s"] > 0 else ""
    print(f"per shot on {cost['ranks']} rank(s), {cost['ranks_per_host']} per host: about {figure(cost['core_hours'])} "
          f"core-hours, {figure(cost['wall_s'] / 3600)} h of wall ({1e3 * cost['step_s']:.3f} ms per step{network}; "
          f"slowest rank {cost['imbalance']:.2f} x the mean)")
    shots = cost["campaign"]["shots"] if "campaign" in cost else 1
    groups = args.tasks // args.ranks_per_shot
    rounds = math.ceil(shots / groups)
    if "campaign" in cost:
        print(f"campaign: {shots} shots, about {figure(cost['campaign']['core_hours'])} core-hours")
    print(f"on {args.tasks} tasks in {groups} group(s) of {args.ranks_per_shot}: {rounds} round(s), "
          f"about {figure(rounds * cost['wall_s'] / 3600)} h of wall time (the steps to the end time at the reference "
          f"shot's rates: a shot decided earlier stops there)")
    whole = cost.get("whole_shots")
    if whole:
        print(f"whole shots: {whole['target_kind']} shots have cost {whole['factor_low']:.2f}-{whole['factor_high']:.2f} "
              f"times the price per step ({whole['shots']} shots measured, {whole['source']}): "
              f"{figure(whole['core_hours_low'])}-{figure(whole['core_hours_high'])} core-hours per shot, "
              f"{figure(rounds * cost['wall_s'] * whole['factor_low'] / 3600)}-"
              f"{figure(rounds * cost['wall_s'] * whole['factor_high'] / 3600)} h of wall time")
    else:
        print(f"whole shots: no {printed['case']['target']['kind']} shot has been measured against the price")
    print(f"calibration: {cost['calibration']}")
    if cost.get("interconnect"):
        print(f"interconnect: {cost['interconnect']}")


if __name__ == "__main__":
    main()

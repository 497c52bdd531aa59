#!/usr/bin/env python3
"""Core-hours a V50 campaign will cost, before it is submitted.

    jobs/cost.py CAMPAIGN.json [--ns-per-node-step 380] [--tasks 64] [--ranks-per-shot 16]

The shot's node count and its step count at the end time (plus a settle's, run.settle) come
from `dea-mpi check` (a shot that is decided earlier stops earlier, so this is an upper
bound). The cost of a node-step
is MEASURED on this machine for the default case (four layers of woven KM2 706 under the
FSP: failures, frequent list rebuilds; docs/performance.md, "Where it stands"): 380 ns when
it was first run, 235-252 ns per core on 1 and 2 ranks since. The default keeps the
first figure as a margin, for requesting wall time; the straight-yarn bench gives 60-70 ns,
and a fabric at rest far from the projectile costs about that. Wall time assumes
the shots spread evenly over the groups and a parallel efficiency of 0.8 within a shot
(ASSUMED; measure it with scripts/bench-scaling.sh on the target cluster).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
parser = argparse.ArgumentParser()
parser.add_argument("campaign")
parser.add_argument("--ns-per-node-step", type=float, default=380.0)
parser.add_argument("--tasks", type=int, default=64)
parser.add_argument("--ranks-per-shot", type=int, default=16)
parser.add_argument("--efficiency", type=float, default=0.8)
args = parser.parse_args()

campaign = json.load(open(args.campaign))
if "case_file" in campaign:
    case_path = os.path.join(os.path.dirname(os.path.abspath(args.campaign)), campaign["case_file"])
else:
    handle, case_path = tempfile.mkstemp(suffix=".json")
    with os.fdopen(handle, "w") as f:
        json.dump(campaign["case"], f)
# a shot's ranks, each share on a host at least as large as this one (check refuses what
# run on them would)
command = [os.path.join(root, "target/release/dea-mpi"), "check", case_path, "--ranks", str(args.ranks_per_shot), "--ranks-per-host", "1"]
checked = subprocess.run(command, capture_output=True, text=True)
if checked.returncode != 0:
    sys.exit(checked.stderr.strip())
checked = json.loads(checked.stdout)
resolved = checked["resolved"]
nodes, steps = resolved["nodes"], resolved["steps"]
# a settle before the shot (run.settle) costs its steps too
settle = checked["case"]["run"].get("settle")
if settle:
    steps += math.ceil(settle["time_s"] / resolved["time_step_s"])
design = campaign["design"]
replicates = campaign.get("replicates", 1)
if design["kind"] == "bisection":
    shots = math.ceil(math.log2((design["high_m_s"] - design["low_m_s"]) / design["resolution_m_s"])) * replicates
elif design["kind"] == "monte_carlo":
    shots = design["shots"]
elif design["kind"] == "velocities":
    shots = len(design["velocities_m_s"])
else:
    shots = design["shots"] * replicates
per_shot = nodes * steps * args.ns_per_node_step * 1e-9 / 3600.0
groups = max(1, args.tasks // args.ranks_per_shot)
wall = math.ceil(shots / groups) * per_shot / (args.ranks_per_shot * args.efficiency)
print(f"{campaign['name']}: {nodes:,} nodes, at most {steps:,.0f} steps per shot, {shots} shots")
print(f"per shot: {per_shot:.2f} core-hours ({args.ns_per_node_step:.0f} ns per node-step)")
print(f"campaign: {shots * per_shot:.1f} core-hours; on {args.tasks} tasks in groups of {args.ranks_per_shot}: about {wall:.2f} h of wall time")

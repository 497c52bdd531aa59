#!/usr/bin/env python3
"""The reference-shot benchmark (issue 32): what a real shot costs, measured on the shot.

    scripts/bench-shot.py [--ranks 1,2] [--window-us 10] [--json]
    scripts/bench-shot.py --binary NEW --baseline OLD [--pairs 3] [--ranks 1]
    scripts/bench-shot.py --pair-multi-rate [--pairs 3] [--ranks 1]

The shot: 4 layers of KM2 style 706, 3 in square, fixed edges, a hybrid fine disc (4 digital
fibres per yarn within 6 mm of the aim point, 1 beyond), the 17-grain FSP at 300 m/s, after
the 5 us settle: the case of `jobs/campaigns/validation/panel-3in-4-layers.json` (567,664
nodes), run by `dea-mpi run` under mpirun for a fixed simulated window (`--window-us`, default
10 us of the shot; the set-up, relaxation and settle are not in the window's wall time).

For each rank count it reports (JSON keys with `--json`):
  core_s_per_simulated_us  wall time x ranks per microsecond of the shot
  ns_per_node_step         wall time x ranks / (nodes x steps)
  rebuilds_per_1000_steps  neighbour-list rebuilds per 1,000 steps (settle and shot)
  relisted_share           share of the nodes held that a rebuild searched afresh (settle
                           and shot)
  stage_seconds            mean seconds per rank of each stage of the shot's steps
  ranks, nodes, steps, simulated_us, wall_s

The cost model that `dea-mpi check` prints (solver/src/cost.rs, docs/theory.md C1) is calibrated
on these measurements: `--calibrate FILE` writes a calibration from the runs just made (their
one-rank runs calibrate, the others are kept to test the model on), `--calibrate-from REPORT`
from a report written earlier with `--json` (plain or paired: the new binary's runs). The
segment graph's counts of the shot come from `dea-mpi partition --ranks 1 --json`. The binary
embeds docs/benchmarks/cost-calibration.json: write that file, then rebuild.

This host's timings drift by +-15 % (DEVELOPERS.md): to compare two binaries, give both
(`--binary` and `--baseline`); they run in alternation (A B, then B A, ...) on the same case
and the report is each pair's ratio of core seconds per simulated microsecond (new / old)
and their median. Never a timed test: this is a benchmark (docs/performance.md).

Multi-rate stepping (`run.multi_rate`, docs/theory.md T1) is opt-in per case: `--multi-rate`
measures the shot with it; `--pair-multi-rate` runs the binary in alternation with it ("new")
and without it ("old") on the same shot, as paired runs.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFERENCE = os.path.join(ROOT, "jobs", "campaigns", "validation", "panel-3in-4-layers.json")
KEYS = ("core_s_per_simulated_us", "ns_per_node_step", "rebuilds_per_1000_steps", "relisted_share",
        "stage_seconds", "ranks", "nodes", "steps", "simulated_us", "wall_s")


def reference_case(window_us, side_m, velocity, multi_rate=False):
    case = json.load(open(REFERENCE))["case"]
    if multi_rate:
        case["run"]["multi_rate"] = True
    case["name"] = "reference-shot"
    case["projectile"]["velocity_m_s"] = velocity
    if side_m is not None:
        case["target"]["side_m"] = side_m
    run = case["run"]
    run["end_time_s"] = window_us * 1e-6
    # a perforation inside the window would end the run early and change what is measured
    run["stop_on_perforation"] = False
    run["snapshot_interval_steps"] = 1000000
    run["checkpoint_interval_minutes"] = 100000.0
    return case


def shoot(binary, case_path, ranks, out):
    command = ["mpirun", "-np", str(ranks)]
    if ranks > (os.cpu_count() or 1):
        command.append("--oversubscribe")
    command += [binary, "run", case_path, "--out", out, "--overwrite"]
    env = dict(os.environ)
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    done = subprocess.run(command, capture_output=True, text=True, env=env)
    if done.returncode != 0:
        sys.exit(f"bench-shot: {' '.join(command)} exited {done.returncode}:\n{done.stderr.strip()[-2000:]}")
    summary = json.load(open(os.path.join(out, "summary.json")))
    steps, nodes, wall = summary["steps"], summary["nodes"], summary["wall_s"]
    simulated_us = summary["simulated_time_s"] * 1e6
    return {
        "core_s_per_simulated_us": wall * ranks / simulated_us,
        "ns_per_node_step": 1e9 * wall * ranks / (nodes * steps),
        # the rebuilds count the settle's too: over the settle's steps and the shot's
        "rebuilds_per_1000_steps": 1000.0 * summary["neighbour_rebuilds"] / (steps + (summary.get("settle") or {}).get("steps", 0)),
        "relisted_share": summary["relisted_share"],
        "stage_seconds": summary["stage_seconds"],
        "ranks": ranks,
        "nodes": nodes,
        "steps": steps,
        "simulated_us": simulated_us,
        "wall_s": wall,
    }


def measured_runs(report):
    """Every run of the measured binary in a report: plain runs, or the new side of pairs."""
    runs = []
    for run in report["runs"]:
        for measured in ([pair["new"] for pair in run["pairs"]] if "pairs" in run else [run]):
            runs.append({"ranks": measured["ranks"], "steps": measured["steps"], "wall_s": measured["wall_s"],
                         "stage_seconds": measured["stage_seconds"]})
    return runs


def write_calibration(report, binary, path, source):
    """The cost model's calibration from a report: its runs, and the shot's graph counts."""
    runs = measured_runs(report)
    if not any(run["ranks"] == 1 for run in runs):
        sys.exit("bench-shot: the cost model is calibrated on one rank: measure with --ranks 1 (and 2 to test it)")
    with tempfile.TemporaryDirectory(prefix="bench-shot-") as scratch:
        case_path = os.path.join(scratch, "reference-shot.json")
        json.dump(reference_case(report["window_us"], None, report["velocity_m_s"]), open(case_path, "w"), indent=1)
        done = subprocess.run([binary, "partition", case_path, "--ranks", "1", "--json"], capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"bench-shot: {binary} partition exited {done.returncode}: {done.stderr.strip()}")
    rank = json.loads(done.stdout)["ranks"][0]
    calibration = {
        "source": source,
        "case": f"the reference shot: {os.path.relpath(REFERENCE, ROOT)} at {report['velocity_m_s']} m/s, "
                f"{report['window_us']} us after its settle",
        "runs": runs,
        "graph": {key: rank[key] for key in ("owned_nodes", "contact_entries", "projectile_candidates")},
        "interconnect": {
            "latency_s": 1.5e-6,
            "bandwidth_bytes_per_s": 12.5e9,
            "basis": "ASSUMED: a typical HDR InfiniBand point-to-point latency and per-rank injection bandwidth; "
                     "replace with the target cluster's",
        },
    }
    with open(path, "w") as f:
        json.dump(calibration, f, indent=1)
        f.write("\n")
    print(f"bench-shot: wrote {path} from {len(runs)} run(s); rebuild so that dea-mpi check uses it", file=sys.stderr)


def describe(label, m):
    stages = sorted(m["stage_seconds"].items(), key=lambda kv: -kv[1])
    top = ", ".join(f"{name} {seconds / max(m['wall_s'], 1e-12):.0%}" for name, seconds in stages[:5])
    print(f"{label}{m['ranks']} rank(s), {m['nodes']:,} nodes, {m['steps']} steps ({m['simulated_us']:.2f} us): "
          f"{m['core_s_per_simulated_us']:.2f} core-s per simulated us, {m['ns_per_node_step']:.1f} ns per node-step, "
          f"{m['rebuilds_per_1000_steps']:.0f} rebuilds per 1,000 steps relisting {m['relisted_share']:.1%} of the nodes; "
          f"largest stages: {top}", file=sys.stderr)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ranks", default="1,2", help="comma-separated rank counts (default 1,2)")
    parser.add_argument("--window-us", type=float, default=10.0, help="simulated microseconds of the shot")
    parser.add_argument("--velocity", type=float, default=300.0, help="striking speed [m/s]")
    parser.add_argument("--side-m", type=float, help="panel side [m] (default: the reference's 3 in; smaller only to try the script)")
    parser.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "dea-mpi"))
    parser.add_argument("--baseline", help="a second binary: run both in alternation and report paired ratios")
    parser.add_argument("--multi-rate", action="store_true", help="the shot with run.multi_rate (docs/theory.md T1)")
    parser.add_argument("--pair-multi-rate", action="store_true", help="pair the binary with multi-rate stepping (new) against it without (old)")
    parser.add_argument("--pairs", type=int, default=3, help="pairs of runs per rank count with --baseline")
    parser.add_argument("--json", action="store_true", help="print the measurements as JSON on stdout")
    parser.add_argument("--calibrate", metavar="FILE", help="write the cost model's calibration from the runs (docs/benchmarks/cost-calibration.json)")
    parser.add_argument("--calibrate-from", metavar="REPORT", help="with --calibrate: take the runs from a report written earlier with --json instead of running")
    args = parser.parse_args()
    if args.calibrate_from:
        if not args.calibrate:
            sys.exit("bench-shot: --calibrate-from REPORT needs --calibrate FILE (where to write)")
        try:
            report = json.load(open(args.calibrate_from))
        except (OSError, ValueError) as e:
            sys.exit(f"bench-shot: {args.calibrate_from}: {e}")
        write_calibration(report, args.binary, args.calibrate, f"{os.path.relpath(os.path.abspath(args.calibrate_from), ROOT)}")
        return
    try:
        ranks = [int(r) for r in args.ranks.split(",")]
    except ValueError:
        sys.exit(f"bench-shot: --ranks {args.ranks!r}: expected comma-separated rank counts, like 1,2")
    if not ranks or min(ranks) < 1:
        sys.exit(f"bench-shot: --ranks {args.ranks!r}: every rank count must be at least 1")
    if not 0.0 < args.window_us <= 100.0:
        sys.exit(f"bench-shot: --window-us must be in (0, 100], got {args.window_us}")
    if args.pair_multi_rate and (args.baseline or args.multi_rate):
        sys.exit("bench-shot: --pair-multi-rate pairs one binary with and without multi-rate stepping: leave --baseline and --multi-rate out")
    if args.pairs < 1:
        sys.exit(f"bench-shot: --pairs must be at least 1, got {args.pairs}")
    for path in [args.binary] + ([args.baseline] if args.baseline else []):
        if not os.access(path, os.X_OK):
            sys.exit(f"bench-shot: {path}: not an executable (build with cargo build --release)")
    with tempfile.TemporaryDirectory(prefix="bench-shot-") as scratch:
        case_path = os.path.join(scratch, "reference-shot.json")
        json.dump(reference_case(args.window_us, args.side_m, args.velocity, args.multi_rate), open(case_path, "w"), indent=1)
        multi_rate_path = os.path.join(scratch, "reference-shot-multi-rate.json")
        json.dump(reference_case(args.window_us, args.side_m, args.velocity, True), open(multi_rate_path, "w"), indent=1)
        report = {"case": "reference-shot", "window_us": args.window_us, "velocity_m_s": args.velocity,
                  "multi_rate": args.multi_rate, "runs": []}
        if args.pair_multi_rate:
            report["paired"] = "new: run.multi_rate, old: single-rate, one binary"
        for n in ranks:
            out = os.path.join(scratch, f"out-{n}")
            if not args.baseline and not args.pair_multi_rate:
                measured = shoot(args.binary, case_path, n, out)
                describe("", measured)
                report["runs"].append(measured)
                continue
            ratios, pairs = [], []
            for k in range(args.pairs):
                # alternate which binary goes first, so a drift of the host falls on both
                if args.pair_multi_rate:
                    order = [("new", args.binary, multi_rate_path), ("old", args.binary, case_path)]
                else:
                    order = [("new", args.binary, case_path), ("old", args.baseline, case_path)]
                if k % 2:
                    order.reverse()
                pair = {label: shoot(path, case, n, out) for label, path, case in order}
                ratio = pair["new"]["core_s_per_simulated_us"] / pair["old"]["core_s_per_simulated_us"]
                ratios.append(ratio)
                pairs.append(pair)
                describe(f"pair {k + 1}, new: ", pair["new"])
                describe(f"pair {k + 1}, old: ", pair["old"])
                print(f"pair {k + 1} on {n} rank(s): new / old = {ratio:.3f}", file=sys.stderr)
            report["runs"].append({"ranks": n, "pairs": pairs, "ratios": ratios, "median_ratio": statistics.median(ratios)})
            print(f"{n} rank(s): new / old core-s per simulated us, median of {len(ratios)} pairs: "
                  f"{statistics.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f})", file=sys.stderr)
    if args.json:
        print(json.dumps(report, indent=1))
    if args.calibrate:
        write_calibration(report, args.binary, args.calibrate, f"scripts/bench-shot.py --ranks {args.ranks}, {args.binary}")


if __name__ == "__main__":
    main()

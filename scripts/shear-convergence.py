#!/usr/bin/python3
"""Shear failure against the element length (issue 31, item 1; docs/validation.md).

Runs shipped cases at element_length_ratio (l0/d) 0.5, 0.25 and 0.125 under each shear
measure ("element", the seed's (5-4) as written, and "gauge", the default) and prints the
breaks by mode and the residual velocity of each run as a Markdown table, and as JSON with
--json. Each run is the binary's `run` on a copy of the case with two fields changed.

  scripts/shear-convergence.py [--binary target/release/dea-mpi] [--ranks 2] \
      [--case cases/four_layer_panel.json ...] [--ratios 0.5 0.25 0.125] [--json out.json]
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time


def set_ratio(case, ratio):
    target = case["target"]
    if "element_length_ratio" in target:
        target["element_length_ratio"] = ratio
    elif isinstance(target.get("weave"), dict):
        target["weave"]["element_length_ratio"] = ratio
    else:
        sys.exit(f"{case.get('name')}: no target.element_length_ratio to vary")


def run_one(binary, ranks, case_path, measure, ratio, scratch):
    with open(case_path) as f:
        case = json.load(f)
    set_ratio(case, ratio)
    case["failure"]["shear_measure"] = measure
    stem = f"{os.path.splitext(os.path.basename(case_path))[0]}-{measure}-{ratio}"
    variant = os.path.join(scratch, stem + ".json")
    with open(variant, "w") as f:
        json.dump(case, f, indent=1)
    out = os.path.join(scratch, stem)
    command = [binary, "run", variant, "--out", out]
    if ranks > 1:
        command = ["mpirun", "--oversubscribe", "-np", str(ranks)] + command
    started = time.time()
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{stem}: exit {done.returncode}\n{done.stderr}")
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return {
        "case": os.path.basename(case_path),
        "shear_measure": measure,
        "element_length_ratio": ratio,
        "nodes": summary["nodes"],
        "broken_tension": summary["broken_elements_tension"],
        "broken_shear": summary["broken_elements_shear"],
        "broken_combined": summary["broken_elements_combined"],
        "residual_velocity_m_s": summary["residual_velocity_m_s"],
        "perforated": summary["perforated"],
        "wall_s": round(time.time() - started, 1),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--binary", default="target/release/dea-mpi")
    parser.add_argument("--ranks", type=int, default=1)
    parser.add_argument("--case", action="append")
    parser.add_argument("--ratios", type=float, nargs="+", default=[0.5, 0.25, 0.125])
    parser.add_argument("--measures", nargs="+", default=["element", "gauge"])
    parser.add_argument("--json")
    args = parser.parse_args()
    cases = args.case or ["cases/four_layer_panel.json", "cases/four_layer_fsp.json"]
    rows = []
    with tempfile.TemporaryDirectory(prefix="dea-shear-") as scratch:
        for case in cases:
            for measure in args.measures:
                for ratio in args.ratios:
                    row = run_one(args.binary, args.ranks, case, measure, ratio, scratch)
                    rows.append(row)
                    print(json.dumps(row), file=sys.stderr, flush=True)
    print("| case | shear measure | l0/d | nodes | tension | shear | combined | residual m/s | perforated |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['case']} | {r['shear_measure']} | {r['element_length_ratio']} | {r['nodes']} | "
            f"{r['broken_tension']} | {r['broken_shear']} | {r['broken_combined']} | "
            f"{r['residual_velocity_m_s']:.1f} | {'yes' if r['perforated'] else 'no'} |"
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()

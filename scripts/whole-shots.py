#!/usr/bin/env python3
"""Whole validation shots against the cost model: what a shot's step cost over its whole run,
set against the step `dea-mpi check` prices from the reference window (docs/theory.md C1).

    scripts/whole-shots.py --write [--binary target/release/dea-mpi]
    scripts/whole-shots.py --check

The cost model is calibrated on the reference shot's first 10 us after its settle, and a whole
shot is not that window: later in it the cone widens, broken ends recoil and the lists are
rebuilt two to three times as often (docs/performance.md, "A whole shot is not the reference
window"). This script measures by how much, from the shot records on file: for each campaign
below, each shot's wall time over its steps (`wall_s / steps` of its record under
`validation/`: set-up, relaxation, settle and every restart's set-up included) over the step
`dea-mpi check CAMPAIGN --ranks R` prices for the shot's R ranks. The campaigns and the
conditions they ran under (the records do not say what else the host was doing) are declared
in `CAMPAIGNS`; only those that had the host to themselves set a target kind's band.

`--write` writes `docs/benchmarks/whole-shots.json`: per campaign its predicted step and each
shot's measured step and factor (measured / predicted), and per target kind (the case's
`target.kind`) the lowest and highest factor of the campaigns in the band. The binary embeds
that file (solver/src/cost.rs, `WholeShots`): `dea-mpi check` prints, beside its price, the
range a whole shot of that kind has cost, and `jobs/cost.py` and `scripts/validation.py status`
read it from check's JSON. Write the file, then rebuild. A shot's commit by `validation.py run
--commit` refreshes its campaign's entry itself (`refresh`: the price the file holds, the new
record's step), so the record and the file land together; a new campaign, a new rank count
or a change of the conditions still takes --write.

`--check` (the test command runs it) re-reads the records and refuses the file when a shot's
steps or wall time, a factor or a band no longer follow from them, naming the entry: a number
in the file is never typed by hand.
"""
import argparse
import importlib.util
import json
import os
import sys
import types

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "docs", "benchmarks", "whole-shots.json")

# the validation script's reading of shot records and its call of `dea-mpi check`
_spec = importlib.util.spec_from_file_location("validation", os.path.join(ROOT, "scripts", "validation.py"))
validation = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(validation)

# (campaign, conditions, whether it sets its kind's band). Conditions are what the session
# notes record; a shot beside another job measures the host's sharing, not the shot.
CAMPAIGNS = [
    ("layers-4-3in-step-3.125", "2 ranks, the host to itself (2026-11-29)", True),
    ("panel-6in-4-layers", "2 ranks, the host to itself (2026-11-29)", True),
    ("mesh-layers-4-3in-7-fibres", "2 ranks; the first four beside a CI run or a build for a third to two "
     "thirds of each shot, the fifth (r000-00004) nearly alone, the sixth (r000-00005) beside a CI run "
     "for most of it", False),
    ("mesh-layers-4-3in-7-fibres-step-3.125", "2 ranks; r000-00000 beside the end of a CI run for its "
     "first ten minutes, then alone; r000-00001 beside a CI run for part of it; r000-00002 nearly alone; "
     "r000-00003 resumed from its checkpoint after a reboot, r000-00003 and r000-00004 beside a session's "
     "editing and short checks (2026-12-01); r000-00005 beside a release build for its first 25 of 82 "
     "minutes (2026-12-02)", False),
    ("yarn-64-d-i0", "2 ranks, other load not recorded (any would only raise the factor)", True),
    ("layers-12-3in", "2 ranks; r000-00002 the host to itself, the other three beside a CI run for part "
     "of the shot (2026-11-30)", False),
    ("mesh-layers-4-3in-l0-0.25-multi-rate", "2 ranks, multi-rate stepping (rates 1 and 4); r000-00000 the "
     "host nearly to itself for its first 55 of 65 minutes, then beside two one-rank probe runs "
     "(2026-12-02)", False),
]

# factors are rounded to this many decimals in the file, so --check compares like with like
DIGITS = 4


def shots_of(name):
    """The shot records of a campaign on file, in id order."""
    records = validation.records(name)
    if not records:
        sys.exit(f"whole-shots: {name}: no shots on record under {os.path.relpath(validation.RESULTS, ROOT)}")
    return [{k: record[k] for k in ("id", "velocity_m_s", "steps", "wall_s", "ranks")} for record in records]


def measured(name, predicted_step_s):
    """Each shot's measured step and its factor over the step predicted for its ranks
    (`predicted_step_s`: {ranks as text: [s]})."""
    rows = []
    for record in shots_of(name):
        step = record["wall_s"] / record["steps"]
        predicted = predicted_step_s.get(str(record["ranks"]))
        if predicted is None:
            sys.exit(f"whole-shots: {name}/{record['id']}: on {record['ranks']} rank(s), "
                     f"no step predicted for that count (run --write)")
        rows.append({**record, "measured_step_s": round(step, 6), "factor": round(step / predicted, DIGITS)})
    return rows


def bands(entries):
    """Per target kind, the lowest and highest factor of the campaigns in the band."""
    factors, campaigns = {}, {}
    for entry in entries:
        if entry["in_band"]:
            factors.setdefault(entry["target_kind"], []).extend(shot["factor"] for shot in entry["shots"])
            campaigns.setdefault(entry["target_kind"], []).append(entry["campaign"])
    return {kind: {"low": min(f), "high": max(f), "shots": len(f), "campaigns": campaigns[kind]}
            for kind, f in factors.items()}


def predicted_step(binary, name, ranks):
    """The step `dea-mpi check --ranks R` prices for a campaign's shot [s], and its target's kind."""
    path = os.path.join(validation.CAMPAIGNS, name + ".json")
    printed = validation.check(types.SimpleNamespace(binary=binary, ranks=ranks), path)
    return printed["resolved"]["cost"]["step_s"], printed["case"]["target"]["kind"]


def write(binary):
    entries = []
    for name, conditions, in_band in CAMPAIGNS:
        steps, kinds = {}, set()
        for ranks in sorted({record["ranks"] for record in shots_of(name)}):
            step_s, kind = predicted_step(binary, name, ranks)
            steps[str(ranks)] = step_s
            kinds.add(kind)
            print(f"{name}: {kind}, predicted {1e3 * step_s:.2f} ms a step on {ranks} rank(s)", file=sys.stderr)
        entries.append({"campaign": name, "target_kind": kinds.pop(), "conditions": conditions,
                        "in_band": in_band, "predicted_step_s": steps, "shots": measured(name, steps)})
    document = {
        "about": ("whole validation shots' wall time per step over the step dea-mpi check prices from "
                  "the reference window (docs/theory.md C1); written by scripts/whole-shots.py --write "
                  "from the shot records under validation/, checked against them by --check"),
        "campaigns": entries,
        "bands": bands(entries),
    }
    dump(document)
    for kind, band in document["bands"].items():
        print(f"{kind}: {band['low']:.2f}-{band['high']:.2f} times the price per step "
              f"({band['shots']} shots of {', '.join(band['campaigns'])})")


def dump(document):
    with open(OUT, "w") as f:
        json.dump(document, f, indent=1)
        f.write("\n")


def refresh(name):
    """Brings `name`'s entry up to the shot records on file, so that the commit which adds a
    record (`validation.py run --commit`) carries a file that --check accepts: its shots are
    measured again against the step the file already prices (a shot's commit does not ask
    `dea-mpi check` again; --write does), and the bands follow. A campaign not in CAMPAIGNS
    leaves the file alone; one the file lacks, or a shot on a rank count it has no price for,
    leaves it alone too and says to run --write. The conditions stay as CAMPAIGNS declares
    them: what else the host was doing is the session's to add. Returns the file's path when
    it was rewritten, else None."""
    if name not in [campaign for campaign, _, _ in CAMPAIGNS]:
        return None
    try:
        with open(OUT) as f:
            document = json.load(f)
    except (OSError, ValueError) as e:
        print(f"whole-shots: {os.path.relpath(OUT, ROOT)}: {e}; not refreshed (run --write)", file=sys.stderr)
        return None
    entries = [e for e in document["campaigns"] if e["campaign"] == name]
    if not entries:
        print(f"whole-shots: {name}: not in {os.path.relpath(OUT, ROOT)} (run --write)", file=sys.stderr)
        return None
    entry = entries[0]
    unpriced = sorted({r["ranks"] for r in shots_of(name)} - {int(k) for k in entry["predicted_step_s"]})
    if unpriced:
        print(f"whole-shots: {name}: no step priced on {', '.join(map(str, unpriced))} rank(s) in "
              f"{os.path.relpath(OUT, ROOT)}; not refreshed (run --write)", file=sys.stderr)
        return None
    shots = measured(name, entry["predicted_step_s"])
    if shots == entry["shots"]:
        return None
    entry["shots"] = shots
    document["bands"] = bands(document["campaigns"])
    dump(document)
    print(f"whole-shots: {os.path.relpath(OUT, ROOT)}: {name} has {len(shots)} shot(s) now; state their "
          f"conditions in scripts/whole-shots.py and rebuild (the binary embeds the file)", file=sys.stderr)
    return OUT


def check():
    """Refuses the file when it no longer follows from the records; returns its problems."""
    try:
        with open(OUT) as f:
            document = json.load(f)
    except (OSError, ValueError) as e:
        return [f"{os.path.relpath(OUT, ROOT)}: {e}"]
    problems = []
    listed = [(e["campaign"], e["conditions"], e["in_band"]) for e in document["campaigns"]]
    if listed != [tuple(c) for c in CAMPAIGNS]:
        problems.append("campaigns: not the script's CAMPAIGNS (run --write)")
    for k, entry in enumerate(document["campaigns"]):
        expected = measured(entry["campaign"], entry["predicted_step_s"])
        if entry["shots"] != expected:
            problems.append(f"campaigns[{k}] ({entry['campaign']}).shots: the records say otherwise "
                            f"({len(expected)} on record, {len(entry['shots'])} in the file; run --write)")
    if document["bands"] != bands(document["campaigns"]):
        problems.append("bands: do not follow from the campaigns' factors (run --write)")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", action="store_true", help=f"write {os.path.relpath(OUT, ROOT)}")
    mode.add_argument("--check", action="store_true", help="refuse the file when the records say otherwise")
    parser.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "dea-mpi"))
    args = parser.parse_args()
    if args.write:
        write(args.binary)
        return
    problems = check()
    for problem in problems:
        print(f"whole-shots: {os.path.relpath(OUT, ROOT)}: {problem}", file=sys.stderr)
    if problems:
        sys.exit(1)
    print(f"whole-shots: {os.path.relpath(OUT, ROOT)} follows from the records")


if __name__ == "__main__":
    main()

#!/usr/bin/env bash
# Benchmark of fabric generation: the default case's KM2 style 706 cell relaxed, then a
# 4-layer 2 in x 2 in panel (1.78 million nodes with 4 fibres per yarn) partitioned and built
# on RANKS ranks (default 2), each rank only its own part plus ghosts; prints dea-mpi
# fabric's report (relaxation, build time and resident memory per node on each rank) and
# the peak resident set of the job. Results: docs/performance.md.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/mpi-env.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
target/release/dea-mpi check cases/km2_706_patch.json | /usr/bin/python3 -c '
import json, sys
case = json.load(sys.stdin)["case"]
case["name"] = "bench-km2-706-2in-4-layers"
case["target"]["side_m"] = 0.0508
json.dump(case, open(sys.argv[1], "w"))' "$work/case.json"
/usr/bin/time -f "peak resident set of one rank: %M kB; wall %e s" "${MPIRUN[@]}" -np "${RANKS:-2}" target/release/dea-mpi fabric "$work/case.json" --out "$work/fabric"

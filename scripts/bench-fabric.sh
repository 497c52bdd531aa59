#!/usr/bin/env bash
# Benchmark of fabric generation: a 4-layer 2 in x 2 in KM2 style 706 hybrid panel (fine
# yarns of FINE digital fibres, default 19, within HALF_WIDTH m of the centre, default
# 6.35 mm; coarse yarns of COARSE fibres, default 4, outside: seed §2.3.4.1): both unit cells
# generated and relaxed, then the panel partitioned and built on RANKS ranks (default 2),
# each rank only its own part plus ghosts. UNIFORM=1 builds the uniform 4-fibre panel
# instead (1.78 million nodes). Prints dea-mpi fabric's report (relaxations, build time and
# resident memory per node on each rank) and the peak resident set of one rank. RADIUS=r
# makes the yarns fine only within r m of the centre instead (a fine disc, theory F12).
# Results: docs/performance.md.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/mpi-env.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
target/release/dea-mpi check cases/km2_706_patch.json | /usr/bin/python3 -c '
import json, os, sys
case = json.load(sys.stdin)["case"]
case["target"]["side_m"] = 0.0508
if os.environ.get("UNIFORM") == "1":
    case["name"] = "bench-km2-706-2in-4-layers"
else:
    case["name"] = "bench-km2-706-2in-4-layers-hybrid"
    case["target"]["weave"]["fibres_per_yarn"] = int(os.environ.get("FINE", "19"))
    region = {"fine_radius_m": float(os.environ["RADIUS"])} if os.environ.get("RADIUS") else {"fine_half_width_m": float(os.environ.get("HALF_WIDTH", "0.00635"))}
    case["target"]["hybrid"] = {**region, "fibres_per_yarn": int(os.environ.get("COARSE", "4"))}
json.dump(case, open(sys.argv[1], "w"))' "$work/case.json"
/usr/bin/time -f "peak resident set of one rank: %M kB; wall %e s" "${MPIRUN[@]}" -np "${RANKS:-2}" target/release/dea-mpi fabric "$work/case.json" --out "$work/fabric"

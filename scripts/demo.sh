#!/usr/bin/env bash
# Sets up and runs the main job: the built-in default case under mpirun. Results go to
# ./out (results.h5, summary.json), on 2 ranks (DEA_RANKS to change); a second demo replaces
# the first one's outputs there (--overwrite).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
source scripts/mpi-env.sh
ranks="${DEA_RANKS:-2}"
"${MPIRUN[@]}" -np "$ranks" target/release/dea-mpi run --out "${1:-out}" --overwrite

#!/usr/bin/env bash
# A longer fuzz run than the test command's: N mutated case files (and campaigns, meshes and
# checkpoints in proportion) from seed SEED, each given to dea-mpi as a user would; fails on a
# panic, a signal, a hang, an undocumented exit code or an error that does not name its file
# (solver/tests/fuzz.rs). The inputs that broke a rule are kept in $TMPDIR/dea-fuzz-*.
#
#     scripts/fuzz.sh [N=2000] [SEED=1]
set -euo pipefail
cd "$(dirname "$0")/.."
DEA_FUZZ_CASES=${1:-2000} DEA_FUZZ_SEED=${2:-1} cargo test --release -p dea-mpi --test fuzz -- --nocapture

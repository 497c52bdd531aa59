#!/usr/bin/env bash
# A longer sample of the rank-identity property test (solver/tests/rank_identity.rs): small
# random cases, each run on 1, 2, 3 and 4 ranks in process (the first also under mpirun on 3)
# and compared bit for bit. A failure prints the case; save it and run it with `dea-mpi run`.
#
#   scripts/rank-identity.sh [CASES [SEED]]    (default: 40 cases, a seed from the clock)
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/mpi-env.sh
cases=${1:-40}
seed=${2:-$(date +%s)}
echo "rank identity: $cases random cases from seed $seed"
DEA_RANK_IDENTITY_CASES=$cases DEA_RANK_IDENTITY_SEED=$seed \
    cargo test --release --locked -p dea-mpi --test rank_identity -- --nocapture

#!/usr/bin/env bash
# Sets up and runs every test: unit and physics tests (cargo), the command-line tests, the
# validation script's bookkeeping, and
# the runs under mpirun, the results opened in ParaView and plotted, the README's tour (its
# quick commands, in order), and the SLURM scripts on
# a single-node SLURM stood up for the purpose; and it counts the contact sweep's
# instructions, so that measurement keeps working.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
source scripts/mpi-env.sh
cargo test --release --locked --workspace
# the validation set's bookkeeping (how re-fired low ends merge into their bisections)
source scripts/packages.sh
ensure_packages test-validation --no-install-recommends python3
/usr/bin/python3 scripts/test-validation.py
# the whole-shot factors the cost model's words quote follow from the shot records
/usr/bin/python3 scripts/whole-shots.py --check
scripts/mpi-tests.sh
scripts/viz-tests.sh
# the README's tour: its block is the script's list, and its quick commands run in order
scripts/tour.sh --check-readme
tour_dir=$(mktemp -d)
TOUR_DIR=$tour_dir scripts/tour.sh --short
rm -rf "$tour_dir"
scripts/slurm-test.sh
scripts/count-instructions.sh

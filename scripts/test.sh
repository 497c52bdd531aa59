#!/usr/bin/env bash
# Sets up and runs every test: unit and physics tests (cargo), the command-line tests, and
# the runs under mpirun, and the results opened in ParaView and plotted.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
source scripts/mpi-env.sh
cargo test --release --locked --workspace
scripts/mpi-tests.sh
scripts/viz-tests.sh

#!/usr/bin/env bash
# Sets up and runs every test: unit and physics tests (cargo), the command-line tests, and
# the runs under mpirun, the results opened in ParaView and plotted, and the SLURM scripts on
# a single-node SLURM stood up for the purpose; and it counts the contact sweep's
# instructions, so that measurement keeps working.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
source scripts/mpi-env.sh
cargo test --release --locked --workspace
scripts/mpi-tests.sh
scripts/viz-tests.sh
scripts/slurm-test.sh
scripts/count-instructions.sh

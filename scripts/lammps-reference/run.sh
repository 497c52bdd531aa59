#!/bin/bash
# LAMMPS on dea-mpi's bench yarn: the per-item costs that issue 2's targets quote, measured
# on this machine (docs/performance.md, "LAMMPS on the bench yarn").
# Usage: scripts/lammps-reference/run.sh [NODES] [STEPS]   (defaults 300000 2000, as the bench)
# Prints one JSON object; the LAMMPS log stays in $LAMMPS_WORK (default a temporary directory).
# LMP names another LAMMPS binary (with GRANULAR and MOLECULE), e.g. one built with -O3.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
nodes="${1:-300000}"
steps="${2:-2000}"
lmp="${LMP:-lmp}"
if [ -z "${LMP:-}" ] && ! command -v lmp >/dev/null; then
    sudo_if_needed=""
    [ "$(id -u)" -ne 0 ] && sudo_if_needed="sudo"
    $sudo_if_needed apt-get install -y -q lammps >&2
fi
work="${LAMMPS_WORK:-$(mktemp -d)}"
mkdir -p "$work"
cd "$work"
/usr/bin/python3 "$here/yarn.py" "$nodes" yarn.data >variables.lammps
source "$here/../mpi-env.sh"
"${MPIRUN[@]}" -np 1 "$lmp" -in "$here/in.yarn" -var steps "$steps" -log log.lammps -screen none >&2
/usr/bin/python3 "$here/parse.py" log.lammps "$(command -v "$lmp")"
echo "LAMMPS log: $work/log.lammps" >&2

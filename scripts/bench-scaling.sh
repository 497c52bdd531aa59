#!/usr/bin/env bash
# Measures the 1 -> 2 rank speed-up of `dea-mpi bench` (300,000+ nodes by default): runs the
# bench on 1 and on 2 ranks, alternating, TRIALS times (this host's timings vary), and prints
# every run and the medians. Usage: scripts/bench-scaling.sh [TRIALS] [extra bench args]
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/mpi-env.sh
trials="${1:-3}"; shift || true
field() { sed -E "s/.*\"$1\":([-0-9.eE+]+).*/\1/" <<<"$2"; }
median() { sort -g | awk '{v[NR]=$1} END {print (NR % 2) ? v[(NR+1)/2] : (v[NR/2] + v[NR/2+1]) / 2}'; }
declare -A walls
for trial in $(seq "$trials"); do
    for ranks in 1 2; do
        report=$("${MPIRUN[@]}" -np "$ranks" target/release/dea-mpi bench --json "$@")
        wall=$(field wall_s "$report")
        walls[$ranks]+="$wall "
        echo "trial $trial, $ranks rank(s): wall $wall s, $(field ns_per_node_step "$report") ns per node-step (core), halo share $(field halo_share "$report"), communication share $(field communication_share "$report"), imbalance $(field load_imbalance "$report"), halo $(field halo_bytes_per_step "$report") bytes/step, ghost fraction $(field ghost_fraction "$report")"
    done
done
one=$(tr ' ' '\n' <<<"${walls[1]}" | grep . | median)
two=$(tr ' ' '\n' <<<"${walls[2]}" | grep . | median)
echo "median wall: 1 rank $one s, 2 ranks $two s, speed-up $(awk -v a="$one" -v b="$two" 'BEGIN {printf "%.3f", a / b}')"

#!/usr/bin/env bash
# Runs small cases under a real mpirun and checks what they write.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/mpi-env.sh
bin=target/release/dea-mpi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
passed=0 failed=0
check() { # name, command...
    local name=$1; shift
    if "$@" >"$work/$name.log" 2>&1; then passed=$((passed + 1)); echo "ok   $name"
    else failed=$((failed + 1)); echo "FAIL $name"; cat "$work/$name.log"; fi
}
# a single-fibre shot on one rank under mpirun writes results and a summary with the keys
check mpirun-one-rank bash -c "'${MPIRUN[0]}' ${MPIRUN[*]:1} -np 1 $bin run cases/single_fibre_short.json --out $work/fibre \
    && /usr/bin/python3 -c 'import json,sys; s=json.load(open(\"$work/fibre/summary.json\")); \
       missing=[k for k in (\"steps\",\"simulated_time_s\",\"wall_s\",\"perforated\",\"residual_velocity_m_s\",\"max_projectile_force_n\",\"node_steps_per_s_per_core\") if k not in s]; \
       sys.exit(1 if missing or s[\"steps\"] <= 0 else 0)' \
    && test -s $work/fibre/results.h5"
# more ranks than this build decomposes for are refused on every rank with exit code 2
check mpirun-two-ranks-refused bash -c "'${MPIRUN[0]}' ${MPIRUN[*]:1} -np 2 $bin run cases/single_fibre_short.json --out $work/two; test \$? -eq 2"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]

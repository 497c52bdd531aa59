#!/usr/bin/env bash
# Counts the instructions the fibre-contact sweep retires on the bench yarn, and those of the
# law and friction alone on the same touching pairs packed (the bench's
# ns_per_contact_pair_packed), under callgrind: exact and repeatable on this host, where
# timings vary by ±15 % and there are no cycle counters, so two builds compare to the
# instruction (design rule "count instructions", docs/performance.md).
# The bench runs at 30,000 nodes for one step: 20 sweeps of the still squeezed yarn, and
# the step's, which meet the same contacts. Valgrind hides AVX-512 from the program, so
# it counts the sweep's AVX2 compilation. Usage: scripts/count-instructions.sh [BINARY]
set -euo pipefail
cd "$(dirname "$0")/.."
binary="${1:-target/release/dea-mpi}"
source scripts/packages.sh
ensure_packages count-instructions valgrind
[ -x "$binary" ] || { echo "count-instructions: no binary at $binary (build it: cargo build --release)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Counts, under callgrind, the instructions of the never-inlined function whose name holds
# $1 (its callees included) and its calls (the calls= line after each call to it; callgrind
# names a function once, by "(id) name", and by "(id)" alone after that): "instructions
# calls", and the bench's JSON report in $work/report.
count() {
    valgrind --tool=callgrind --toggle-collect="*$1*" --callgrind-out-file="$work/out" "$binary" bench --json --nodes 30000 --steps 1 >"$work/report" 2>"$work/log" || { cat "$work/log" >&2; exit 1; }
    local calls
    calls=$(awk -v name="$1" '$0 ~ "^c?fn=\\([0-9]+\\) .*" name {match($0, /\([0-9]+\)/); id = substr($0, RSTART, RLENGTH)}
        id != "" && index($0, "cfn=" id) == 1 {getline; split($1, c, "="); n += c[2]} END {print n + 0}' "$work/out")
    [ "${calls:-0}" -gt 0 ] || { echo "count-instructions: callgrind saw no call to $1 in $binary" >&2; exit 1; }
    echo "$(sed -n 's/^summary: //p' "$work/out") $calls"
}
field() { sed -E "s/.*\"$1\":([-0-9.eE+]+).*/\1/" "$work/report"; }
read -r instructions sweeps < <(count add_fibre_contacts_compiled_for)
awk -v i="$instructions" -v s="$sweeps" -v n="$(field nodes)" -v t="$(field static_contacts_per_node)" -v l="$(field listed_pairs_per_node)" 'BEGIN {
    printf "fibre-contact sweep: %d instructions in %d sweeps of %d nodes\n", i, s, n
    printf "  %.1f per node, %.1f per touching entry (%.2f touching and %.2f listed entries per node)\n", i / s / n, i / s / (n * t), t, l
}'
# the law and friction alone on the same touching pairs packed (bench key
# ns_per_contact_pair_packed): one rank, so each pair once
read -r instructions sweeps < <(count PackedPairs::sweep)
awk -v i="$instructions" -v s="$sweeps" -v n="$(field nodes)" -v t="$(field static_contacts_per_node)" 'BEGIN {
    printf "packed law and friction: %d instructions in %d sweeps of %d touching pairs\n", i, s, n * t / 2
    printf "  %.1f per pair (the sweep: twice its figure per touching entry)\n", i / s / (n * t / 2)
}'

#!/usr/bin/env bash
# Checks the results against the tools users open them with: installs Debian's ParaView,
# Xvfb, h5py and matplotlib when missing, runs the four-layer panel on 2 ranks, opens its
# fields.xdmf in ParaView (arrays, time steps, an offscreen PNG) and draws the plots of
# scripts/plot-run.py; relaxes the default case's woven cell and opens its cell.xdmf. Debian's Python modules need /usr/bin/python3.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/mpi-env.sh
source scripts/packages.sh
ensure_packages viz-tests --no-install-recommends paraview python3-paraview xvfb xauth python3-matplotlib python3-h5py
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
passed=0 failed=0
check() { # name, command...
    local name=$1; shift
    if "$@" >"$work/$name.log" 2>&1; then passed=$((passed + 1)); echo "ok   $name"; tail -n 1 "$work/$name.log"
    else failed=$((failed + 1)); echo "FAIL $name"; cat "$work/$name.log"; fi
}
check panel-with-snapshots "${MPIRUN[@]}" -np 2 target/release/dea-mpi run cases/four_layer_panel.json --out "$work/panel"
check paraview-opens-the-run /usr/bin/python3 scripts/paraview-check.py "$work/panel" "$work/panel/fields.png"
check image-is-not-empty test -s "$work/panel/fields.png"
check plots /usr/bin/python3 scripts/plot-run.py "$work/panel"
check fabric-of-the-default-case target/release/dea-mpi fabric --out "$work/fabric"
check paraview-opens-the-cell /usr/bin/python3 scripts/paraview-cell.py "$work/fabric"
check fabric-of-a-3d-weave target/release/dea-mpi fabric cases/weave3d_km2_orthogonal_small.json --out "$work/weave3d"
check paraview-opens-the-3d-cell /usr/bin/python3 scripts/paraview-cell.py "$work/weave3d"
check plots-are-not-empty bash -c "for f in projectile energies energy_by_layer back_face panel_side; do test -s $work/panel/plots/\$f.png || exit 1; done"
check campaign-plot bash -c "target/release/dea-mpi v50 cases/v50_tiny_monte_carlo.json --out $work/v50 >/dev/null 2>&1 && /usr/bin/python3 scripts/plot-campaign.py $work/v50 && test -s $work/v50/v50.png"
# the committed traces of the 6 in panel's shots (validation.py writes one beside each record)
check traces-plot bash -c "/usr/bin/python3 scripts/plot-traces.py panel-6in-4-layers --out $work/traces.png && test -s $work/traces.png"
# 12 layers: one small axes a shot, the layers in number order (broken_layer_10 after _9, not after _1)
check traces-plot-of-12-layers bash -c "/usr/bin/python3 scripts/plot-traces.py layers-12-3in --out $work/traces-12.png && test -s $work/traces-12.png"
check traces-layers-in-number-order /usr/bin/python3 -c "
import importlib.util, sys
sys.path.insert(0, 'scripts')
spec = importlib.util.spec_from_file_location('plot_traces', 'scripts/plot-traces.py')
plot_traces = importlib.util.module_from_spec(spec)
spec.loader.exec_module(plot_traces)
trace = {'time_s': [], 'broken_layer_10': [], 'broken_layer_2': [], 'broken_layer_0': [], 'broken_layer_11': [], 'broken_layer_1': []}
order = plot_traces.layer_columns(trace)
assert order == ['broken_layer_0', 'broken_layer_1', 'broken_layer_2', 'broken_layer_10', 'broken_layer_11'], order
print('layers in number order')"
check traces-plot-names-an-unknown-campaign bash -c "! /usr/bin/python3 scripts/plot-traces.py no-such-campaign --out $work/none.png 2>$work/none.err && grep -q \"no campaign 'no-such-campaign'\" $work/none.err"
# the validation figures of docs/img, drawn from the committed validation/summary.json and traces
check validation-plot bash -c "/usr/bin/python3 scripts/plot-validation.py --out $work/validation-v50.png && test -s $work/validation-v50.png"
check single-yarn-plots bash -c "/usr/bin/python3 scripts/plot-single-yarn.py --out $work/single-yarn.png --friction-out $work/single-yarn-friction.png && test -s $work/single-yarn.png && test -s $work/single-yarn-friction.png"
check residuals-plot bash -c "/usr/bin/python3 scripts/plot-residuals.py --out $work/validation-residuals.png && test -s $work/validation-residuals.png"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]

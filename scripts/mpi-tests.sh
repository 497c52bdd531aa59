#!/usr/bin/env bash
# Runs cases under a real mpirun (1 to 4 ranks, oversubscribed on small machines) and checks
# what they write: the same bits on every rank count, collective errors, the benchmark.
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
# mpi RANKS ARGS...: dea-mpi under mpirun (exported for the bash -c checks)
export bin work MPIRUN_LINE="${MPIRUN[*]}"
mpi() { local ranks=$1; shift; $MPIRUN_LINE -np "$ranks" "$bin" "$@"; }
export -f mpi

# a single-fibre shot on one rank writes results and a summary with every key
check one-rank-summary bash -c 'mpi 1 run cases/single_fibre_short.json --out $work/fibre \
    && for key in steps simulated_time_s wall_s perforated residual_velocity_m_s max_projectile_force_n \
           node_steps_per_s_per_core stage_seconds halo_bytes_per_step ghost_fraction load_imbalance; do
           grep -q "\"$key\"" $work/fibre/summary.json || { echo "summary lacks $key"; exit 1; }; done \
    && test -s $work/fibre/results.h5'
# the four-layer panel (contacts, friction, plasticity, Weibull strengths, failures) gives
# the same bits in every dataset on 1, 2, 3 and 4 ranks
check panel-one-rank bash -c 'mpi 1 run cases/four_layer_panel.json --out $work/panel1 && grep -q "\"broken_elements_tension\": [1-9]" $work/panel1/summary.json'
for ranks in 2 3 4; do
    check "panel-identical-on-$ranks-ranks" bash -c "mpi $ranks run cases/four_layer_panel.json --out \$work/panel$ranks \
        && \$bin compare \$work/panel1/results.h5 \$work/panel$ranks/results.h5 \
        && grep -q '\"ranks\": $ranks' \$work/panel$ranks/summary.json"
done
# a meshed FSP striking obliquely and yawed: the same bits on 1 and 3 ranks
check meshed-fsp-identical-on-3-ranks bash -c 'mpi 1 run cases/four_layer_fsp.json --out $work/fsp1 && mpi 3 run cases/four_layer_fsp.json --out $work/fsp3 \
    && $bin compare $work/fsp1/results.h5 $work/fsp3/results.h5'
# a deformable sphere (elastic hexahedra on rank 0, surface broadcast): the same bits on 1 and 4 ranks
check deformable-identical-on-4-ranks bash -c 'mpi 1 run cases/four_layer_deformable_sphere.json --out $work/def1 && mpi 4 run cases/four_layer_deformable_sphere.json --out $work/def4 \
    && $bin compare $work/def1/results.h5 $work/def4/results.h5'
# a projectile mesh file that does not exist ends every rank with exit code 4, named once
/usr/bin/python3 -c 'import json, sys; c = json.load(open("cases/four_layer_fsp.json")); c["projectile"] = {"shape": "file", "mesh_file": "nowhere.stl", "mass_kg": 2e-6, "velocity_m_s": 500.0}; json.dump(c, sys.stdout)' >"$work/nomesh.json"
check missing-mesh-on-two-ranks bash -c 'mpi 2 run $work/nomesh.json --out $work/nomesh 2>$work/nomesh.err; code=$?; cat $work/nomesh.err; \
    test $code -eq 4 && test "$(grep -c "nowhere.stl" $work/nomesh.err)" -eq 1'
# a bad case ends every rank with exit code 3 and one message naming the field
printf '{"name":"x","target":{"kind":"straight_yarn","yarn":"km2_600_denier","fibres_per_yarn":0,"length_m":0.01,"element_length_ratio":0.5},"contact":{"law":"elastic","friction_coefficient":0,"projectile_friction_coefficient":0},"failure":{"mode":"none"},"projectile":{"preset":"table_4_2_sphere","velocity_m_s":100},"run":{"end_time_s":1e-6}}' >"$work/bad.json"
check bad-case-on-two-ranks bash -c 'mpi 2 run $work/bad.json --out $work/bad 2>$work/bad.err; code=$?; cat $work/bad.err; \
    test $code -eq 3 && test "$(grep -c "target.fibres_per_yarn" $work/bad.err)" -eq 1'
check missing-file-on-two-ranks bash -c 'mpi 2 run $work/none.json --out $work/none; test $? -eq 4'
# more ranks than the case has segments to share is a usage error on every rank
printf '{"name":"tiny","target":{"kind":"single_fibre","length_m":2e-4,"diameter_m":5e-5,"element_length_ratio":0.5},"contact":{"law":"elastic","friction_coefficient":0,"projectile_friction_coefficient":0},"failure":{"mode":"none"},"projectile":{"preset":"table_4_2_sphere","velocity_m_s":100},"run":{"end_time_s":1e-8}}' >"$work/tiny.json"
check too-many-ranks bash -c 'mpi 4 run $work/tiny.json --out $work/tiny 2>$work/tiny.err; code=$?; cat $work/tiny.err; test $code -eq 2 && grep -q "segments" $work/tiny.err'
# a panic on one rank ends the whole job at once, not at a scheduler's time limit
check panic-aborts-the-job bash -c 'start=$(date +%s); timeout 120 bash -c "mpi 2 run cases/four_layer_panel.json --out $work/panic --panic-on-rank 1"; code=$?; \
    test $code -ne 0 && test $code -ne 124 && test $(( $(date +%s) - start )) -lt 60'
# a signal makes every rank finish its step, write a checkpoint and exit 75; the run then
# continues on another number of ranks and ends with the same bits as an uninterrupted one.
# SIGTERM goes to the ranks (as SLURM sends it to every task), SIGUSR1 to mpirun, which
# forwards it
sed 's/"end_time_s": 3e-6/"end_time_s": 3e-5, "stop_on_perforation": false/' cases/four_layer_panel.json >"$work/long.json"
check long-reference bash -c 'mpi 2 run $work/long.json --out $work/reference'
check sigterm-checkpoints-and-exits-75 bash -c 'mpi 2 run $work/long.json --out $work/term 2>$work/term.err & runner=$!; sleep 3;     pkill -TERM -f "^$bin run $work/long.json --out $work/term"; wait $runner; code=$?; echo "exit $code"; cat $work/term.err;     test $code -eq 75 && test -f $work/term/checkpoint/manifest.h5 && test ! -e $work/term/results.h5 \
    && grep -q "checkpoint written at step [0-9]*, t = " $work/term.err \
    && grep -q "\"state\": \"interrupted\"" $work/term/progress.json'
check restart-on-three-ranks-is-identical bash -c 'mpi 3 run --restart $work/term/checkpoint --out $work/term     && $bin compare $work/reference/results.h5 $work/term/results.h5'
check sigusr1-through-mpirun bash -c '$MPIRUN_LINE -np 2 $bin run $work/long.json --out $work/usr1 & runner=$!; sleep 3;     kill -USR1 $runner; wait $runner; code=$?; echo "exit $code"; test $code -eq 75 && test -f $work/usr1/checkpoint/manifest.h5'
# Ctrl-C at a terminal checkpoints and exits 75 too; a SIGTERM or Ctrl-C sent to mpirun itself
# reaches the ranks as SIGTERM (they checkpoint), though mpirun then reports 1 (docs/output.md)
check sigint-checkpoints-and-exits-75 bash -c '$bin run $work/long.json --out $work/int & runner=$!; sleep 3; \
    kill -INT $runner; wait $runner; code=$?; echo "exit $code"; test $code -eq 75 && test -f $work/int/checkpoint/manifest.h5'
# under mpirun at a terminal (script(1) gives mpirun one) rank 0 draws its bar; asked for
# lines, it writes plain lines and no bar
check bar-under-mpirun-at-a-terminal bash -c 'script -qec "$MPIRUN_LINE -np 2 $bin run cases/four_layer_fsp.json --out $work/bar" $work/bar.tty >/dev/null \
    && grep -aq "m/s, balance" $work/bar.tty \
    && script -qec "$MPIRUN_LINE -np 2 $bin run cases/four_layer_fsp.json --out $work/lines --progress lines" $work/lines.tty >/dev/null \
    && ! grep -aq "m/s, balance" $work/lines.tty && grep -aq "results in" $work/lines.tty'
# the batch scripts' wrapper: a checkpoint stop under mpirun reads as one line, not mpirun's
# boxed abort report
check requeue-wrapper-reports-a-checkpoint-in-one-line bash -c 'source jobs/requeue.sh; \
    (sleep 3; pkill -USR1 -f "^mpirun.* --out $work/requeue") & \
    run_requeueable $MPIRUN_LINE -np 2 $bin run $work/long.json --out $work/requeue 2>$work/requeue.err; code=$?; sleep 1; \
    cat $work/requeue.err; test $code -eq 75 && grep -q "every rank wrote its checkpoint part and stopped" $work/requeue.err \
    && ! grep -q "Primary job" $work/requeue.err && grep -q "checkpoint written at step" $work/requeue.err \
    && grep -q "^stopped: a signal asked the run to stop" $work/requeue.err'
check sigterm-to-mpirun-checkpoints bash -c '$MPIRUN_LINE -np 2 $bin run $work/long.json --out $work/mpiterm & runner=$!; sleep 3; \
    kill -TERM $runner; wait $runner; echo "exit $?"; test -f $work/mpiterm/checkpoint/manifest.h5 \
    && $bin run $work/long.json --restart $work/mpiterm/checkpoint --out $work/mpiterm'
check truncated-checkpoint-refused bash -c 'part=$work/usr1/checkpoint/part-00000.h5; head -c 2000 $part >$part.cut && mv $part.cut $part;     mpi 2 run --restart $work/usr1/checkpoint --out $work/usr1 2>$work/cut.err; code=$?; cat $work/cut.err;     test $code -eq 4 && grep -q "part-00000.h5" $work/cut.err'
# the benchmark runs under mpirun and reports every key
# the woven fabric: the relaxed cell is the same on 1, 2 and 4 ranks, and the default case
# (the validation set's 1 in panel of four layers of KM2 706 struck by the FSP at 300 m/s)
# runs on 2 ranks until the FSP is through, and says where that stands in the validation set
check fabric-cell-identical-on-1-2-4-ranks bash -c 'for r in 1 2 4; do mpi $r fabric --out $work/fabric$r || exit 1; done; \
    $bin compare $work/fabric1/cell.h5 $work/fabric2/cell.h5 && $bin compare $work/fabric1/cell.h5 $work/fabric4/cell.h5 && test -f $work/fabric4/cell.xdmf'
# a hybrid panel (fine and coarse yarns) settled before the shot: the same bits on 1 and 4
# ranks, and `dea-mpi fabric` writes both cells
check hybrid-settled-identical-on-4-ranks bash -c 'mpi 1 run cases/hybrid_two_layer_settle.json --out $work/hyb1 && mpi 4 run cases/hybrid_two_layer_settle.json --out $work/hyb4 \
    && $bin compare $work/hyb1/results.h5 $work/hyb4/results.h5 && grep -q "\"largest_force_after_n\"" $work/hyb4/summary.json \
    && mpi 2 fabric cases/hybrid_two_layer_settle.json --out $work/hybfabric && test -f $work/hybfabric/coarse_cell.h5 && test -f $work/hybfabric/coarse_cell.xdmf'
# a hybrid panel with a fine disc: fine fibres tied to coarse ones across the ranks' borders,
# the same bits on 1 and 3 ranks; `dea-mpi fabric` reports the ties
check hybrid-disc-identical-on-3-ranks bash -c 'mpi 1 run cases/hybrid_disc_two_layer_settle.json --out $work/disc1 && mpi 3 run cases/hybrid_disc_two_layer_settle.json --out $work/disc3 \
    && $bin compare $work/disc1/results.h5 $work/disc3/results.h5 && mpi 2 fabric cases/hybrid_disc_two_layer_settle.json --out $work/discfabric \
    && grep -q "\"ties\": 64" $work/discfabric/fabric.json'
# a 3-D weave cell: rank 0 relaxes it, the same bits under 1 and 2 ranks; a weave whose binders
# have no room to turn ends both ranks with exit 3 and one message naming the field
check weave3d-cell-on-two-ranks bash -c 'mpi 1 fabric cases/weave3d_km2_orthogonal_small.json --out $work/w3d1 \
    && mpi 2 fabric cases/weave3d_km2_orthogonal_small.json --out $work/w3d2 && $bin compare $work/w3d1/cell.h5 $work/w3d2/cell.h5 && test -f $work/w3d2/cell.xdmf'
/usr/bin/python3 -c 'import json, sys; c = json.load(open("cases/weave3d_km2_orthogonal_small.json")); c["target"]["weave"]["pick_spacing_m"] = 0.5e-3; json.dump(c, sys.stdout)' >"$work/tight3d.json"
check weave3d-without-room-on-two-ranks bash -c 'mpi 2 fabric $work/tight3d.json --out $work/tight3d 2>$work/tight3d.err; code=$?; cat $work/tight3d.err; \
    test $code -eq 3 && test "$(grep -c "pick_spacing_m" $work/tight3d.err)" -eq 1'
# a panel tiled from that cell, struck: the same bits on 1 and 2 ranks
check weave3d-panel-identical-on-2-ranks bash -c 'mpi 1 run cases/weave3d_km2_orthogonal_panel.json --out $work/w3p1 \
    && mpi 2 run cases/weave3d_km2_orthogonal_panel.json --out $work/w3p2 && $bin compare $work/w3p1/results.h5 $work/w3p2/results.h5'
check default-case-on-two-ranks bash -c 'mpi 2 run --out $work/default | tee $work/default.log && grep -q "\"perforated\": true" $work/default/summary.json \
    && grep -q "\"outcome\": \"perforated\"" $work/default/summary.json && grep -q "; perforated: residual velocity .* m/s along the line of flight;" $work/default.log \
    && grep -q "default case: the first shot of the validation set.s 1 in panel series" $work/default.log && grep -q "the model.s V50 of 4 layers by panel side (validation/summary.json): .*25.4 mm" $work/default.log'
# V50 campaigns: two groups of one rank fire the Monte Carlo shots with the same bits as one
# rank alone; a bisection on one group of two ranks; a group size that does not divide
check v50-groups-give-the-same-shots bash -c 'mpi 1 v50 cases/v50_tiny_monte_carlo.json --out $work/mc1 && mpi 2 v50 cases/v50_tiny_monte_carlo.json --out $work/mc2 --ranks-per-shot 1 \
    && for shot in $work/mc1/shots/*/; do $bin compare $shot/results.h5 $work/mc2/shots/$(basename $shot)/results.h5 >/dev/null || exit 1; done \
    && test $(ls $work/mc2/shots/*.json | wc -l) -eq 16 && grep -q git_commit $work/mc2/provenance.json'
check v50-bisection-two-ranks-per-shot bash -c 'mpi 2 v50 cases/v50_tiny_bisection.json --out $work/bisection --ranks-per-shot 2 | tee $work/bisection.log && grep -q "bisection 0: between" $work/bisection.log'
# two groups of one rank on this host shoot at once: the host must hold both shots' targets
/usr/bin/python3 -c 'import json, sys; c = json.load(open("cases/v50_tiny_shot.json")); c["target"]["side_m"] = 10.0; json.dump(c, sys.stdout)' >"$work/v50_huge_shot.json"
/usr/bin/python3 -c 'import json, sys; c = json.load(open("cases/v50_tiny_monte_carlo.json")); c["case_file"] = "v50_huge_shot.json"; json.dump(c, sys.stdout)' >"$work/v50_huge.json"
check v50-groups-share-the-host-memory bash -c 'mpi 2 v50 $work/v50_huge.json --out $work/huge --ranks-per-shot 1 2>$work/huge.err; code=$?; cat $work/huge.err; \
    test $code -eq 3 && grep -q "on each of the 1 ranks they are split over" $work/huge.err && grep -q "the job.s 2 ranks on this host" $work/huge.err'
check v50-ranks-per-shot-must-divide bash -c 'mpi 2 v50 cases/v50_tiny_bisection.json --out $work/nodiv --ranks-per-shot 3; test $? -eq 2'
check bench-on-two-ranks bash -c 'mpi 2 bench --json --nodes 20000 --steps 40 >$work/bench.json && cat $work/bench.json \
    && for key in nodes steps ranks wall_s ns_per_node_step ns_per_contact_pair ns_per_contact_pair_packed ns_per_node_rods ns_per_node_rebuild contacts_per_node halo_share ghost_fraction; do
           grep -q "\"$key\"" $work/bench.json || { echo "bench lacks $key"; exit 1; }; done && grep -q "\"ranks\":2" $work/bench.json'
# the reference-shot benchmark's script, on a 2 cm cut of its panel for a few steps: its
# paired mode runs the binary against itself and reports every key (no timing is judged)
check bench-shot-keys bash -c '/usr/bin/python3 scripts/bench-shot.py --ranks 2 --window-us 0.05 --side-m 0.02 --binary $bin --baseline $bin --pairs 1 --json >$work/shot.json \
    && /usr/bin/python3 -c "import json, sys; r = json.load(open(sys.argv[1]))[\"runs\"][0]; m = r[\"pairs\"][0][\"new\"]
missing = [k for k in (\"core_s_per_simulated_us\", \"ns_per_node_step\", \"rebuilds_per_1000_steps\", \"relisted_share\", \"stage_seconds\", \"ranks\", \"nodes\") if k not in m]
assert not missing and m[\"ranks\"] == 2 and r[\"median_ratio\"] > 0 and 0 < m[\"relisted_share\"] <= 1, (missing, m)" $work/shot.json'
# its multi-rate pairing: one binary with and without run.multi_rate on the same cut
check bench-shot-pairs-multi-rate bash -c '/usr/bin/python3 scripts/bench-shot.py --ranks 1 --window-us 0.05 --side-m 0.02 --binary $bin --pair-multi-rate --pairs 1 --json >$work/shot-mr.json \
    && /usr/bin/python3 -c "import json, sys; r = json.load(open(sys.argv[1])); p = r[\"runs\"][0][\"pairs\"][0]
assert \"run.multi_rate\" in r[\"paired\"] and abs(p[\"new\"][\"steps\"] - p[\"old\"][\"steps\"]) <= 1 and r[\"runs\"][0][\"median_ratio\"] > 0, r" $work/shot-mr.json'
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]

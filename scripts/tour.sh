#!/usr/bin/env bash
# The five-minute tour of README.md, every command in order, as a newcomer would type them:
#
#   scripts/tour.sh                 every command (writes out/; about 1.5 h with the [long] ones)
#   scripts/tour.sh --short         the quick ones only (lines marked [long] skipped), as the
#                                   test suite runs it, in a scratch directory
#   scripts/tour.sh --check-readme  whether README.md's tour block is this script's list
#
# README.md's tour block is the list below, verbatim; the test suite checks that it agrees
# and runs the short tour, so neither can go stale. Each command's failure stops the tour
# and names the command. TOUR_DIR=DIR runs in DIR (the repository's cases, scripts, jobs,
# docs and binary linked there) instead of the repository itself.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
read -r -d '' TOUR <<'LIST' || true
source scripts/mpi-env.sh   # as root: lets Open MPI run; MPIRUN=(mpirun --oversubscribe)
target/release/dea-mpi run --out out/default   # [long] the default: the validation set's 1 in panel, 4 layers of KM2 style 706 (4 fibres per yarn within 6 mm, 1 beyond), 17-grain FSP at 300 m/s (about 5 min on 1 rank)
target/release/dea-mpi fabric --out out/fabric   # relax the default case's woven cell: out/fabric/{cell.h5, cell.xdmf, fabric.json}
target/release/dea-mpi fabric cases/km2_706_28_layer_disc.json --share 0/64 --out out/share   # [long] what rank 0 of a 64-rank job holds of a 2.1e8-node panel (1 min)
mpirun -np 4 --oversubscribe target/release/dea-mpi run cases/four_layer_panel.json --out out/panel4   # a four-layer panel on 4 ranks (checkpoints every 500 steps)
target/release/dea-mpi run cases/four_layer_panel.json --out out/panel1   # ... and on 1
target/release/dea-mpi compare out/panel1/results.h5 out/panel4/results.h5   # identical, bit for bit
mpirun -np 3 --oversubscribe target/release/dea-mpi run --restart out/panel4/checkpoint --out out/panel4   # continue from its last checkpoint on 3 ranks (as after a SIGTERM/SIGUSR1: checkpoint, exit 75)
target/release/dea-mpi compare out/panel1/results.h5 out/panel4/results.h5   # still identical
target/release/dea-mpi check cases/seed_6_1_single_fibre.json   # validate and print the resolved case, with its price in core-hours (resolved.cost)
target/release/dea-mpi partition cases/four_layer_panel.json --ranks 4   # predicted owned/ghost nodes, imbalance, halo bytes
mpirun -np 2 --oversubscribe target/release/dea-mpi bench --json --nodes 20000 --steps 50   # cost per node-step and per stage (the default 300,010 nodes for a measurement)
source scripts/packages.sh && ensure_packages tour --no-install-recommends paraview python3-paraview xvfb xauth python3-matplotlib python3-h5py   # what the pictures need (Debian's ParaView, Xvfb, matplotlib, h5py)
/usr/bin/python3 scripts/paraview-check.py out/panel4   # open fields.xdmf in ParaView (on its own Xvfb without a display): every documented field there, no broken element drawn; out/panel4/fields.png
/usr/bin/python3 scripts/plot-run.py out/panel4   # velocity and force, energies by kind, energy per layer, back-face deflection, side view: out/panel4/plots/
target/release/dea-mpi run cases/four_layer_fsp.json --out out/fsp   # an oblique, yawed, meshed FSP; open out/fsp/projectile.xdmf beside fields.xdmf
mpirun -np 2 --oversubscribe target/release/dea-mpi v50 cases/v50_tiny_monte_carlo.json --out out/v50 --ranks-per-shot 1   # a V50 campaign of a 3 mm toy on 2 groups
/usr/bin/python3 scripts/plot-campaign.py out/v50   # its probability of perforation against velocity, with the shots: out/v50/v50.png
target/release/dea-mpi check cases/v50_tiny_bisection.json   # validate a campaign and its shot's case
target/release/dea-mpi check cases/km2_706_28_layer_disc.json --ranks 256 --ranks-per-host 8   # partitioned as run would (2 min): does each host hold its ranks' shares (the largest 2.8 GB; --ranks-per-host 32 on a 24 GB host is refused), and what a shot costs
jobs/cost.py cases/v50_tiny_bisection.json --ranks-per-shot 1 --tasks 2   # core-hours of a case or a campaign before submitting it, as check prices it (jobs/README.md: SLURM scripts)
LOCAL=1 RANKS=1 jobs/v50-layer-sweep.sh cases/v50_tiny_bisection.json out/sweep 1 2 && /usr/bin/python3 scripts/plot-layer-sweep.py out/sweep   # V50 against layers from a campaign template (the 3 mm toy; jobs/campaigns/table_6_1_*.json for Table 6-1 on a cluster)
/usr/bin/python3 scripts/plot-validation.py --out out/validation-v50.png   # the validation set's V50 by panel size so far, beside the seed's Table 6-1
/usr/bin/python3 scripts/plot-residuals.py --out out/validation-residuals.png   # the 3 in panel's shots: residual against striking velocity, with the Lambert–Jonas fits
/usr/bin/python3 scripts/plot-traces.py panel-6in-4-layers --out out/traces-6in.png   # the 6 in panel's shots: speed along the shot line and elements broken per layer against time, from their committed traces
target/release/dea-mpi fit validation/layers-4-3in validation/layers-4-3in-step-6.25   # V50 from the shots of two series of one panel (25 and 6.25 m/s steps), pooled; a different target is refused
scripts/bench-scaling.sh   # [long] 1 -> 2 rank speed-up of the bench
scripts/bench-shot.py --ranks 1,2   # [long] what a real shot costs: the 3 in reference shot, 10 us, core-s per simulated us (~15 min; --baseline OLD for paired ratios)
scripts/count-instructions.sh   # [long] instructions the fibre-contact sweep retires per touching entry (callgrind: exact, for A/B on a noisy host)
scripts/lammps-reference/run.sh   # [long] the bench's yarn in LAMMPS (installs Debian's lammps): its per-item costs as JSON (~3 min)
/usr/bin/python3 scripts/validate-fabric.py --out out/fabric-validation   # [long] seed ch. 3: relaxed style 706 for 1/4/7/19 fibres per yarn (~1 min)
/usr/bin/python3 scripts/validate-projectile-mesh.py   # [long] seed ch. 4: meshed vs analytic projectiles, Table 4-5 moduli (~50 min)
scripts/bench-fabric.sh   # [long] relax + build a 4-layer 2 in hybrid panel (19 fibres per yarn within 6.35 mm, 4 beyond: 7.3 M nodes): time, memory per node
LIST

readme_block() {
    awk '/^## Five-minute tour/ { tour = 1 } tour && /^```sh$/ { inside = 1; next } inside && /^```$/ { exit } inside' "$root/README.md"
}

case "${1:-}" in
    --check-readme)
        if diff <(readme_block) <(printf '%s\n' "$TOUR") >/dev/null; then
            echo "README.md's tour is scripts/tour.sh's list"
            exit 0
        fi
        echo "README.md's tour block differs from scripts/tour.sh's list (< README, > script):"
        diff <(readme_block) <(printf '%s\n' "$TOUR") || true
        exit 1
        ;;
    --short) short=1 ;;
    "") short=0 ;;
    *) echo "usage: scripts/tour.sh [--short | --check-readme]" >&2; exit 2 ;;
esac

if [ -n "${TOUR_DIR:-}" ]; then
    mkdir -p "$TOUR_DIR/target"
    for entry in cases scripts jobs docs validation README.md; do ln -sfn "$root/$entry" "$TOUR_DIR/$entry"; done
    ln -sfn "$root/target/release" "$TOUR_DIR/target/release"
    cd "$TOUR_DIR"
fi
if [ -e out/panel4 ] || [ -e out/panel1 ]; then
    echo "tour: $PWD/out holds an earlier tour's runs, and a run refuses a directory another run wrote: remove $PWD/out first" >&2
    exit 2
fi
[ -x target/release/dea-mpi ] || { echo "tour: no target/release/dea-mpi: run scripts/setup.sh (or scripts/demo.sh) first" >&2; exit 2; }
count=0 skipped=0
while IFS= read -r line; do
    if [ "$short" -eq 1 ] && [[ $line == *"# [long]"* ]]; then
        skipped=$((skipped + 1))
        continue
    fi
    echo "tour \$ $line"
    started=$SECONDS
    # eval: a line may source a file or set variables for the lines after it; stdin is not
    # the list's (mpirun forwards its stdin to rank 0 and would read the rest of the tour)
    if ! eval "$line" </dev/null; then
        echo "tour: FAILED after $((SECONDS - started)) s: $line" >&2
        exit 1
    fi
    echo "tour: done in $((SECONDS - started)) s"
    count=$((count + 1))
done <<<"$TOUR"
echo "tour: $count commands ran, $skipped [long] ones skipped, in $SECONDS s"

#!/usr/bin/env bash
# A V50 campaign per layer count, as one SLURM job array:
#   jobs/v50-layer-sweep.sh TEMPLATE.json OUTDIR [LAYERS...]     (default 1 4 8 12 16 20 24 28)
# TEMPLATE is a campaign whose case is inline ("case": {...}) or beside it ("case_file");
# OUTDIR/L/campaign.json gets target.layers = L, and array task k runs the k-th layer count
# through jobs/v50-campaign.sbatch's requeueable runner. Resources go to sbatch as usual:
#   SBATCH_ARGS="--ntasks=64 --time=12:00:00" RANKS_PER_SHOT=16 jobs/v50-layer-sweep.sh ...
# LOCAL=1 runs the campaigns one after the other under mpirun here instead (RANKS, default 2).
# When they are done: scripts/plot-layer-sweep.py OUTDIR (table and plot against the seed's
# Table 6-1). Estimate the cost first: jobs/cost.py OUTDIR/28/campaign.json
set -euo pipefail
cd "$(dirname "$0")/.."
template=${1:?usage: jobs/v50-layer-sweep.sh TEMPLATE.json OUTDIR [LAYERS...]}
out=${2:?usage: jobs/v50-layer-sweep.sh TEMPLATE.json OUTDIR [LAYERS...]}
shift 2
layers=("${@:-1 4 8 12 16 20 24 28}")
layers=(${layers[*]})
mkdir -p "$out"
for l in "${layers[@]}"; do
    mkdir -p "$out/$l"
    python3 - "$template" "$l" "$out/$l/campaign.json" <<'PY'
import json, os, sys
template, layers, target = sys.argv[1], int(sys.argv[2]), sys.argv[3]
campaign = json.load(open(template))
if "case_file" in campaign:
    campaign["case"] = json.load(open(os.path.join(os.path.dirname(os.path.abspath(template)), campaign.pop("case_file"))))
campaign["case"]["target"]["layers"] = layers
campaign["name"] = f"{campaign['name']}-{layers}-layers"
json.dump(campaign, open(target, "w"), indent=1)
PY
done
printf '%s\n' "${layers[@]}" >"$out/layers.txt"
if [ -n "${LOCAL:-}" ]; then
    source scripts/mpi-env.sh
    for l in "${layers[@]}"; do
        "${MPIRUN[@]}" -np "${RANKS:-2}" target/release/dea-mpi v50 "$out/$l/campaign.json" --out "$out/$l" --ranks-per-shot "${RANKS_PER_SHOT:-1}" 2>/dev/null
    done
else
    # shellcheck disable=SC2086
    sbatch ${SBATCH_ARGS:-} --array=0-$((${#layers[@]} - 1)) jobs/v50-array.sbatch "$out" "${RANKS_PER_SHOT:-}"
fi

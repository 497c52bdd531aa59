#!/usr/bin/env bash
# Generates and relaxes the 3-D weave cells of cases/weave3d_*.json (seed chapter 3's weave
# types with its Nicalon CG and S-glass yarns; the weave dimensions are ours, as the seed gives
# them only as pictures) and prints the table docs/validation.md quotes. About 20 minutes on
# this machine. Usage: scripts/validate-3d-weaves.sh [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-target/validate-3d-weaves}
mkdir -p "$out"
cargo build --release --quiet
for case in cases/weave3d_*.json; do
    name=$(basename "$case" .json)
    target/release/dea-mpi fabric "$case" --out "$out/$name" > "$out/$name.log"
done
/usr/bin/python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
print("| case | nodes | iterations | residual reduction | thickness before -> after (mm) | change | crimp (binder / filler / stuffer) | fibre volume fraction |")
print("|---|---|---|---|---|---|---|---|")
for report in sorted(out.glob("weave3d_*/fabric.json")):
    r = json.loads(report.read_text())
    x = r["relaxation"]
    crimp = " / ".join(f"{100 * r['crimp_by_role'][k]:.2f} %" if k in r["crimp_by_role"] else "-" for k in ("binder", "filler", "stuffer"))
    print(f"| {r['case']} | {r['nodes']} | {x['iterations']} | {x['final_residual_n'] / x['initial_residual_n']:.1e} | "
          f"{1e3 * x['before']['thickness_m']:.3f} -> {1e3 * r['cell']['thickness_m']:.3f} | {100 * r['thickness_change']:+.1f} % | {crimp} | {r['cell']['fibre_volume_fraction']:.3f} |")
PY

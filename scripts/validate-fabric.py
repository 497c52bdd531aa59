#!/usr/bin/python3
"""Seed chapter 3: the relaxed KM2 style 706 unit cell for 1, 4, 7 and 19 digital fibres per
yarn (`dea-mpi fabric` on each), against the style's published figures: 180 g/m^2 (DuPont,
as PHYSICS.md §6 quotes it) and a thickness usually quoted near 0.23 mm (unverified here,
docs/theory.md F1). The table is printed and written to OUT/table.md; with --update-docs it
also replaces the one in docs/validation.md between the fabric markers (a tracked file: a
maintainer's step, not a newcomer's).

    python3 scripts/validate-fabric.py [--out out/validate-fabric] [--update-docs]
"""
import argparse
import json
import os
import subprocess

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
binary = os.path.join(root, "target/release/dea-mpi")
parser = argparse.ArgumentParser()
parser.add_argument("--out", default=os.path.join(root, "out/validate-fabric"))
parser.add_argument("--update-docs", action="store_true", help="also rewrite the table in docs/validation.md")
args = parser.parse_args()
os.makedirs(args.out, exist_ok=True)

rows = []
for fibres in [1, 4, 7, 19]:
    case = json.loads(subprocess.run([binary, "check", os.path.join(root, "cases/km2_706_patch.json")], check=True, capture_output=True, text=True).stdout)["case"]
    case["name"] = f"km2-706-{fibres}-fibres"
    case["target"]["weave"]["fibres_per_yarn"] = fibres
    case["target"]["side_m"] = 0.003
    case["target"]["layers"] = 1
    path = os.path.join(args.out, f"{fibres}.json")
    with open(path, "w") as f:
        json.dump(case, f, indent=1)
    out = os.path.join(args.out, str(fibres))
    subprocess.run([binary, "fabric", path, "--out", out], check=True, capture_output=True)
    with open(os.path.join(out, "fabric.json")) as f:
        report = json.load(f)
    r, c, b = report["relaxation"], report["cell"], report["relaxation"]["before"]
    rows.append(
        f"| {fibres} | {r['iterations']} | {report['relaxation_s']:.2f} | {r['final_residual_n'] / r['initial_residual_n']:.1e} "
        f"| {1e6 * b['thickness_m']:.0f} → {1e6 * c['thickness_m']:.0f} | {100 * b['crimp']:.2f} → {100 * c['crimp']:.2f} "
        f"| {1e6 * c['yarn_width_m']:.0f} × {1e6 * c['yarn_thickness_m']:.0f} | {c['fibre_volume_fraction']:.3f} "
        f"| {1e3 * c['areal_density_kg_m2']:.1f} ({100 * report['style_706_areal_density_deviation']:+.1f} %) | {100 * r['largest_overlap_ratio']:.0f} % |"
    )
    print(rows[-1], flush=True)

lines = [
    "<!-- fabric:begin (written by scripts/validate-fabric.py) -->",
    "",
    "| fibres per yarn | iterations | relaxation [s] | force reduction | thickness [µm] | crimp [%] | yarn width × thickness [µm] | fibre volume fraction | areal density [g/m²] | deepest contact |",
    "|---|---|---|---|---|---|---|---|---|---|",
    *rows,
    "",
    "<!-- fabric:end -->",
]
block = "\n".join(lines)
with open(os.path.join(args.out, "table.md"), "w") as f:
    f.write(block + "\n")
print(f"written to {os.path.join(args.out, 'table.md')}")
if not args.update_docs:
    raise SystemExit(0)
validation = os.path.join(root, "docs/validation.md")
with open(validation) as f:
    text = f.read()
begin, end = text.find("<!-- fabric:begin"), text.find("<!-- fabric:end -->")
text = text[:begin] + block + text[end + len("<!-- fabric:end -->"):] if begin >= 0 else text.rstrip() + "\n\n" + block + "\n"
with open(validation, "w") as f:
    f.write(text)
print(f"written to {validation}")

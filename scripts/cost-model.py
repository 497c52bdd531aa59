#!/usr/bin/env python3
"""Cost model of a 28-layer 12 in x 12 in KM2 panel shot on 64-1024 ranks.

Measured inputs (docs/performance.md, this machine, `dea-mpi bench` and
`scripts/bench-scaling.sh`) are marked MEASURED; interconnect figures are ASSUMED (typical
HDR InfiniBand) and should be replaced by the target cluster's. Prints a Markdown table.
Usage: scripts/cost-model.py
"""
import math

# --- measured on this machine ---------------------------------------------------------
# A shot is priced at what a woven shot costs, not the straight-yarn bench (66 ns per
# node-step, a rebuild every 65 steps): the default case, four layers of KM2 706 struck by
# the FSP at 400 m/s, 1 rank (docs/performance.md, "Default case").
NS_PER_NODE_STEP = 253.0      # MEASURED: default case, core time per node-step (all stages)
NS_PER_GHOST_STEP = 19.0      # MEASURED: default case, rods per node-step; ghosts get rods only
HALO_BYTES_PER_GHOST = 32     # MEASURED: position + failure state per ghost per step
RECORD_BYTES_PER_GHOST = 96   # code: full ghost record at a rebuild (12 words)
STEPS_PER_REBUILD = 8.4       # MEASURED: default case on 2 ranks, 638 rebuilds in 5,350 steps (docs/performance-log.md, 2026-11)
BYTES_PER_NODE = 1730         # MEASURED: peak RSS / nodes of the 300,010-node bench
IMBALANCE = 1.01              # MEASURED: bench on 2 ranks, slowest / mean compute
COLLECTIVES_PER_STEP = 6      # code: projectile broadcast, displacement max, error min, reaction gather (2), rebuild vote (past half a skin; counted in every step)
REACTION_BYTES = 56           # code: gid, force, torque per touching node, to rank 0

# --- assumed --------------------------------------------------------------------------
LATENCY_S = 1.5e-6            # ASSUMED: MPI point-to-point latency between nodes
BANDWIDTH_B_S = 12.5e9        # ASSUMED: per-rank injection bandwidth
PARTNERS = 8                  # ASSUMED: neighbours of a rank's column (2-D decomposition)
TOUCHING_NODES = 1.1e4        # ESTIMATE: 17-grain FSP face (23 mm2) on a 19-fibre layer

# --- problem (docs PHYSICS.md section 8) ------------------------------------------------
PANEL_SIDE_M = 0.3048
LAYER_THICKNESS_M = 0.23e-3
LAYERS = 28
GHOST_DEPTH_M = 84e-6          # 3 l0 = 1.5 d along fibres, >= 1.5 d ghost reach across (contact diameter plus two skins)
STEPS_PER_SHOT = 100e-6 / 1.8e-9

CASES = {
    # name: (nodes, area holding the nodes [m2])
    # the disc panel as generated (docs/performance.md, fabric generation); about half its nodes lie outside the disc,
    # so placing all in it overstates the ghosts: conservative
    "fine disc (19 fibres within 1 in of the impact, 1 outside): 2.09e8 nodes": (2.09e8, math.pi * 0.0254 ** 2),
    "uniform 19 fibres per yarn: 4.7e9 nodes": (4.7e9, PANEL_SIDE_M ** 2),
}


def step_time(nodes, area, ranks):
    thickness = LAYERS * LAYER_THICKNESS_M
    volume = area * thickness
    per_rank = nodes / ranks
    # a rank's region: a column through the thickness while it is wider than thick,
    # otherwise a cube; ghosts fill a shell of GHOST_DEPTH_M around it
    side = math.sqrt(area / ranks)
    if side > thickness:
        shell = 4 * side * thickness * GHOST_DEPTH_M
    else:
        cube = (volume / ranks) ** (1 / 3)
        shell = 6 * cube ** 2 * GHOST_DEPTH_M
    ghosts = min(shell * nodes / volume, nodes - per_rank)
    compute = (per_rank * NS_PER_NODE_STEP + ghosts * NS_PER_GHOST_STEP) * 1e-9 * IMBALANCE
    halo = 2 * PARTNERS * LATENCY_S + ghosts * HALO_BYTES_PER_GHOST / BANDWIDTH_B_S
    collectives = COLLECTIVES_PER_STEP * 2 * LATENCY_S * math.log2(ranks) + TOUCHING_NODES * REACTION_BYTES / BANDWIDTH_B_S
    rebuild = (4 * PARTNERS * LATENCY_S + 1.5 * ghosts * RECORD_BYTES_PER_GHOST / BANDWIDTH_B_S + ranks * 48 / BANDWIDTH_B_S) / STEPS_PER_REBUILD
    return per_rank, ghosts, compute, halo + collectives + rebuild


print(f"steps per shot: {STEPS_PER_SHOT:.2e}\n")
for name, (nodes, area) in CASES.items():
    print(f"### {name}\n")
    print("| ranks | nodes per rank | ghost fraction | memory per rank | step: compute | step: communication | parallel efficiency | wall per shot | core-hours per shot |")
    print("|---|---|---|---|---|---|---|---|---|")
    serial = nodes * NS_PER_NODE_STEP * 1e-9
    for ranks in (64, 128, 256, 512, 1024):
        per_rank, ghosts, compute, comm = step_time(nodes, area, ranks)
        step = compute + comm
        efficiency = serial / (ranks * step)
        wall = step * STEPS_PER_SHOT
        memory = (per_rank + ghosts) * BYTES_PER_NODE / 2 ** 30
        print(f"| {ranks} | {per_rank:.2e} | {ghosts / per_rank:.3f} | {memory:.1f} GiB | {compute * 1e3:.2f} ms | {comm * 1e3:.3f} ms | {efficiency:.2f} | {wall / 3600:.2f} h | {ranks * wall / 3600:.0f} |")
    print()

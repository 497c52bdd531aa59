#!/usr/bin/python3
"""Reads the log of in.yarn and prints, as one JSON object, LAMMPS's costs per item in the
units of `dea-mpi bench --json` (solver/src/bench.rs), from LAMMPS's own stage timers.

Usage: parse.py log.lammps BINARY
"""
import json
import re
import sys


def runs(text):
    """Each run's thermo rows, loop time, steps, atoms, section times, neighbours, builds."""
    found = []
    for block in re.split(r"\n(?=Per MPI rank memory)", text)[1:]:
        loop = re.search(r"Loop time of (\S+) on \d+ procs for (\d+) steps with (\d+) atoms", block)
        sections = {m.group(1): float(m.group(2)) for m in re.finditer(r"^(\w+)\s+\|\s+\S+\s+\|\s+(\S+)\s+\|", block, re.M)}
        rows = [[float(v) for v in line.split()] for line in re.findall(r"^\s+\d+\s+\d+\s+\d+\s*$", block, re.M)]
        found.append({
            "loop_s": float(loop.group(1)),
            "steps": int(loop.group(2)),
            "atoms": int(loop.group(3)),
            "sections": sections,
            "touching_rows": [row[2] for row in rows],
            "neighbours": int(re.search(r"Total # of neighbors = (\d+)", block).group(1)),
            "builds": int(re.search(r"Neighbor list builds = (\d+)", block).group(1)),
        })
    return found


def main():
    text = open(sys.argv[1]).read()
    found = runs(text)
    if len(found) != 4:
        sys.exit(f"{sys.argv[1]}: {len(found)} finished runs, in.yarn makes 4 (did LAMMPS stop early? see the log)")
    static, rebuild, dynamic, integrate = found
    nodes = static["atoms"]
    # compute contact/atom counts each touching pair at both of its atoms
    static_pairs = static["touching_rows"][0] / 2
    dynamic_pairs = sum(dynamic["touching_rows"]) / len(dynamic["touching_rows"]) / 2
    node_steps = nodes * dynamic["steps"]
    pair_static = static["sections"]["Pair"] / static["steps"]
    report = {
        "code": text.splitlines()[0].strip() + ": gran/hertz/history, bond and angle harmonic",
        "binary": sys.argv[2],
        "nodes": nodes,
        "steps": dynamic["steps"],
        # the elastic Hertz yarn flies apart in the timed steps, where the KM2 one stays
        # together: not comparable with the bench's (docs/performance.md)
        "ns_per_node_step": dynamic["loop_s"] * 1e9 / node_steps,
        "ns_per_contact_pair": pair_static * 1e9 / static_pairs,
        "static_contacts_per_node": 2 * static_pairs / nodes,
        # LAMMPS's half list counts a pair once (dea-mpi's full lists list it at both nodes)
        "static_listed_pairs_per_node": static["neighbours"] / nodes,
        "ns_per_node_pair_stage": dynamic["sections"]["Pair"] * 1e9 / node_steps,
        "contacts_per_node": 2 * dynamic_pairs / nodes,
        "listed_pairs_per_node_at_end": dynamic["neighbours"] / nodes,
        "ns_per_node_bonds": dynamic["sections"]["Bond"] * 1e9 / node_steps,
        "ns_per_node_integrate": integrate["sections"]["Modify"] * 1e9 / (nodes * integrate["steps"]),
        # the squeezed yarn's lists, rebuilt at each of its evaluations: the build (Neigh)
        # and the carrying over of the shear histories (Modify: fix neigh/history)
        "ns_per_node_neighbour_build": rebuild["sections"]["Neigh"] * 1e9 / (nodes * rebuild["builds"]),
        "ns_per_node_history_carry": rebuild["sections"]["Modify"] * 1e9 / (nodes * rebuild["builds"]),
        "rebuilds": dynamic["builds"],
        "stage_seconds": dynamic["sections"],
    }
    report["ns_per_node_rods"] = report["ns_per_node_bonds"] + report["ns_per_node_integrate"]
    report["ns_per_node_rebuild"] = report["ns_per_node_neighbour_build"] + report["ns_per_node_history_carry"]
    print(json.dumps(report, indent=1))


main()

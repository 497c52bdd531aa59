#!/usr/bin/python3
"""Writes the LAMMPS data file of dea-mpi's bench yarn (solver/src/bench.rs) as a bonded
chain of granular spheres: 19 KM2 digital fibres packed hexagonally at the contact
diameter, squeezed to 97 % of that pitch, nodes l0 = d/2 apart along x.

Usage: yarn.py NODES OUT.data   (NODES: at least this many nodes, as `dea-mpi bench --nodes`)
"""
import math
import sys

FIBRES = 19
AREA = 0.6 / 9000.0 / 1440.0 / FIBRES  # KM2 600 denier yarn over 19 fibres [m^2]
DENSITY = 1440.0  # KM2 [kg/m^3]
DIAMETER = math.sqrt(4.0 * AREA / math.pi)  # digital fibre [m]
ELEMENT = 0.5 * DIAMETER  # l0 [m]
# modified contact diameter, seed (3-1)-(3-3): the granular contact distance
CONTACT = DIAMETER * math.sqrt(1.0 + (ELEMENT / DIAMETER / 2.0) ** 2)
SQUEEZE = 0.97


def hexagonal_packing(count, pitch):
    """The 1 + 6 + 12 centres of dea_fabric::hexagonal_packing, ring by ring."""
    points = []
    for a in range(-3, 4):
        for b in range(-3, 4):
            x, y = (a + 0.5 * b) * pitch, b * math.sqrt(3.0) / 2.0 * pitch
            r = math.hypot(x, y)
            points.append((round(r / pitch), r, math.atan2(y, x), x, y))
    points.sort()
    return [(p[3], p[4]) for p in points[:count]]


def write_chain_runs(f, per_fibre, span):
    """Numbered lines of type 1 naming every run of `span` consecutive atoms along each
    fibre: the bonds (span 2) and the angles (span 3)."""
    line = 0
    for fibre in range(FIBRES):
        for k in range(per_fibre - span + 1):
            line += 1
            first = fibre * per_fibre + k + 1
            f.write(f"{line} 1 " + " ".join(str(first + m) for m in range(span)) + "\n")


def main():
    nodes, out = int(sys.argv[1]), sys.argv[2]
    per_fibre = math.ceil(nodes / FIBRES)
    mass = DENSITY * AREA * ELEMENT  # lumped node mass rho A l0 [kg]
    # LAMMPS gives a sphere the mass of its volume: the density that carries the node mass
    sphere_density = mass / (math.pi * CONTACT**3 / 6.0)
    centres = hexagonal_packing(FIBRES, CONTACT)
    n = FIBRES * per_fibre
    length = (per_fibre - 1) * ELEMENT
    radius = max(math.hypot(*c) for c in centres) * SQUEEZE
    with open(out, "w") as f:
        f.write("dea-mpi bench yarn as a bonded granular chain\n\n")
        f.write(f"{n} atoms\n{FIBRES * (per_fibre - 1)} bonds\n{FIBRES * (per_fibre - 2)} angles\n")
        f.write("2 atom types\n1 bond types\n1 angle types\n\n")
        pad = ELEMENT
        box = 2.0 * radius + CONTACT
        f.write(f"{-pad} {length + pad} xlo xhi\n{-box} {box} ylo yhi\n{-box} {box} zlo zhi\n\n")
        f.write("Atoms # hybrid sphere angle\n\n")
        for fibre, (y, z) in enumerate(centres):
            for k in range(per_fibre):
                atom = fibre * per_fibre + k + 1
                kind = 2 if k in (0, per_fibre - 1) else 1  # 2: clamped ends
                f.write(f"{atom} {kind} {k * ELEMENT:.9e} {y * SQUEEZE:.9e} {z * SQUEEZE:.9e} {CONTACT:.9e} {sphere_density:.9e} {fibre + 1}\n")
        f.write("\nBonds\n\n")
        write_chain_runs(f, per_fibre, 2)
        f.write("\nAngles\n\n")
        write_chain_runs(f, per_fibre, 3)
    modulus = 84.62e9  # KM2 longitudinal (Table 4-1) [Pa]
    inertia = math.pi * DIAMETER**4 / 64.0
    print(f"variable length equal {length:.9e}")
    print(f"variable yarn_radius equal {radius + 0.5 * CONTACT:.9e}")
    print(f"variable contact equal {CONTACT:.9e}")
    # bond_style harmonic: E = K (r - r0)^2, so K = EA / (2 l0)
    print(f"variable bond_k equal {modulus * AREA / (2.0 * ELEMENT):.9e}")
    print(f"variable element equal {ELEMENT:.9e}")
    # angle_style harmonic: E = K (theta - pi)^2 with the bending spring EI / l0 halved
    print(f"variable angle_k equal {modulus * inertia / ELEMENT / 2.0:.9e}")


main()

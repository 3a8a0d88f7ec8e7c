#!/usr/bin/python3
"""Generate the OPLS-AA n-decane melt in inputs/alkane (conf.gro, topol.top, decane.itp).

    /usr/bin/python3 inputs/make_alkane.py            # build unless inputs/alkane/conf.gro exists
    /usr/bin/python3 inputs/make_alkane.py --force    # rebuild (the same files)

Model: 100 n-decanes (C10H22, 3200 atoms) with GROMACS's oplsaa.ff: CH3 carbons opls_135, CH2
carbons opls_136, hydrogens opls_140; bonds, angles, Ryckaert-Bellemans dihedrals and 1-4 pairs
(gen-pairs, fudge 0.5, geometric combination rule) from the force field's tables. Cubic box at the
experimental liquid density at 300 K, 0.726 g/cm^3.

Recipe:
  1. one all-trans decane from ideal geometry (C-C 0.1529 nm, C-H 0.109 nm, tetrahedral angles);
  2. `gmx insert-molecules` places 100 randomly oriented copies in the box (fixed seed; vdW radii
     scaled down so that the molecules fit at liquid density);
  3. vimd minimises the box (steepest descent, C-H bonds rigid: constraints = "h-bonds");
  4. vimd equilibrates it: RATTLE with h-bonds at 2 fs, v-rescale, reaction field eps_rf = infinity,
     cut-off 0.9 nm; 50 ps at 500 K (the chains leave their all-trans start), then 100 ps at 300 K,
     whose last frame (with velocities) is conf.gro.
vimd runs on one thread, so a rebuild reproduces the files.
"""
import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "validation"))
from gmx_common import gmx_env  # noqa: E402  (Debian's GROMACS on VMs that hide rdtscp)

CARBONS = 10
MOLECULES = 100
DENSITY = 726.0                  # kg/m^3, n-decane at 300 K
MOLAR_MASS = CARBONS * 12.011 + (2 * CARBONS + 2) * 1.008  # g/mol, oplsaa.ff's masses
AVOGADRO = 6.02214076e23
BOX = (MOLECULES * MOLAR_MASS / AVOGADRO * 1e-3 / DENSITY) ** (1 / 3) * 1e9  # nm
ATOMS = 3 * CARBONS + 2          # per molecule
CC, CH = 0.1529, 0.109           # nm, oplsaa.ff's CT-CT and CT-HC b0
TETRAHEDRAL = np.arccos(-1 / 3)
SEED = 20261126
# insert-molecules' vdW radius factor: its default 0.57 fits only ~80 molecules; at 0.5 no two atoms
# are so close that a force exceeds what vimd accepts in a start state (1e6 kJ/mol/nm).
INSERT_SCALE = 0.5
HOT_TEMPERATURE = 500.0          # K
HOT_STEPS = 25000                # 50 ps at 2 fs
TEMPERATURE = 300.0              # K
NVT_STEPS = 50000                # 100 ps at 2 fs

FORCEFIELD = """[forcefield]
cutoff = 0.9
vdw_modifier = "potential-shift"
coulomb = "reaction-field"
epsilon_rf = 0.0
"""


def decane_geometry():
    """All-trans chain in the xy plane: carbon positions and, per carbon, its hydrogens."""
    half = TETRAHEDRAL / 2
    step = np.array([CC * np.sin(half), CC * np.cos(half), 0.0])
    # Carbons zigzag along x; the two ends get a virtual neighbour continuing the zigzag, so
    # every carbon's hydrogens are placed the same way.
    zig = [np.array([k * step[0], (k % 2) * step[1], 0.0]) for k in range(-1, CARBONS + 1)]
    carbons, hydrogens = zig[1:-1], []
    for k in range(1, CARBONS + 1):
        c, a, b = zig[k], zig[k - 1], zig[k + 1]
        out = 2 * c - a - b
        out /= np.linalg.norm(out)
        normal = np.cross(a - c, b - c)
        normal /= np.linalg.norm(normal)
        hs = [c + CH * (np.cos(half) * out + sign * np.sin(half) * normal) for sign in (1, -1)]
        if k in (1, CARBONS):  # the methyl's third hydrogen where the chain would continue
            virtual = a if k == 1 else b
            hs.append(c + CH * (virtual - c) / np.linalg.norm(virtual - c))
        hydrogens.append(hs)
    return carbons, hydrogens


def decane_files():
    """decane.gro (one molecule) and decane.itp: atoms, bonds, and every angle, dihedral and 1-4
    pair of the bond graph; parameters come from oplsaa.ff by bonded type."""
    carbons, hydrogens = decane_geometry()
    atoms, positions, bonds = [], [], []
    carbon_index = []
    for k, (c, hs) in enumerate(zip(carbons, hydrogens), start=1):
        methyl = k in (1, CARBONS)
        atoms.append(("opls_135" if methyl else "opls_136", f"C{k}", -0.18 if methyl else -0.12))
        positions.append(c)
        carbon_index.append(len(atoms))
        if k > 1:
            bonds.append((carbon_index[-2], carbon_index[-1]))
        for j, h in enumerate(hs, start=1):
            atoms.append(("opls_140", f"H{k}{j}", 0.06))
            positions.append(h)
            bonds.append((carbon_index[-1], len(atoms)))
    neighbours = {i: set() for i in range(1, len(atoms) + 1)}
    for i, j in bonds:
        neighbours[i].add(j)
        neighbours[j].add(i)
    angles = sorted((a, b, c) for b in neighbours for a in neighbours[b] for c in neighbours[b] if a < c)
    dihedrals = sorted((a, b, c, d) for b, c in bonds for a in neighbours[b] - {c} for d in neighbours[c] - {b})
    pairs = sorted({(min(a, d), max(a, d)) for a, _, _, d in dihedrals})  # a tree: no pair is also 1-2 or 1-3

    itp = ["; n-decane, OPLS-AA (oplsaa.ff), written by inputs/make_alkane.py", "[ moleculetype ]", "DEC 3", "",
           "[ atoms ]"]
    itp += [f"{i:5d} {t} 1 DEC {name:<4} {i:3d} {q:+.3f}" for i, (t, name, q) in enumerate(atoms, start=1)]
    for title, rows, function in (("bonds", bonds, 1), ("pairs", pairs, 1), ("angles", angles, 1),
                                  ("dihedrals", dihedrals, 3)):
        itp += ["", f"[ {title} ]"] + [" ".join(f"{i:3d}" for i in row) + f" {function}" for row in rows]
    gro = ["n-decane, all-trans", f"{len(atoms)}"]
    gro += [f"{1:5d}{'DEC':<5}{name:>5}{i:5d}{x[0]:8.3f}{x[1]:8.3f}{x[2]:8.3f}"
            for i, ((_, name, _), x) in enumerate(zip(atoms, positions), start=1)]
    gro.append(f"{3.0:10.5f}{3.0:10.5f}{3.0:10.5f}")
    return "\n".join(gro) + "\n", "\n".join(itp) + "\n"


TOPOLOGY = f"""; {MOLECULES} OPLS-AA n-decanes, written by inputs/make_alkane.py
#include "oplsaa.ff/forcefield.itp"
#include "decane.itp"

[ system ]
n-decane melt

[ molecules ]
DEC {MOLECULES}
"""


def run(cmd, cwd, env=None):
    p = subprocess.run([str(c) for c in cmd], cwd=cwd, text=True, capture_output=True, env=env)
    if p.returncode != 0:
        sys.exit(f"make_alkane.py: {' '.join(map(str, cmd))} failed:\n{p.stdout[-2000:]}\n{p.stderr[-2000:]}")
    return p.stdout


def vimd_run(vimd, work, name, text):
    (work / f"{name}.toml").write_text(text)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    run([vimd, "run", work / f"{name}.toml", "--out", work / f"out_{name}"], work, env)
    return json.loads((work / f"out_{name}" / "summary.json").read_text())


def report(minimised, energy_csv):
    """The minimised potential and the equilibration's averages over its second half (and the
    potential over its quarters: a trend there means the melt has not settled)."""
    rows = np.genfromtxt(energy_csv, delimiter=",", names=True)
    last = rows[len(rows) // 2:]
    quarters = [q["potential"].mean() / MOLECULES for q in np.array_split(rows, 4)]
    per_molecule = {k: last[k].mean() / MOLECULES for k in ("potential", "lj", "coulomb", "dihedrals")}
    print(f"minimised: potential {minimised['potential']:.1f} kJ/mol after {minimised['steps']} steps, "
          f"largest force {minimised['max_force']:.1f} kJ/mol/nm")
    print(f"NVT, last {last['time'][-1] - last['time'][0]:.0f} ps: T = {last['temperature'].mean():.1f} K, "
          + ", ".join(f"{k} {v:.2f}" for k, v in per_molecule.items()) + " kJ/mol per molecule, "
          f"constraint RMS {last['constraint_rms'].max():.1e}; potential per molecule by quarter "
          + " ".join(f"{q:.2f}" for q in quarters))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--force", action="store_true", help="rebuild even if inputs/alkane/conf.gro exists")
    ap.add_argument("--vimd", default=str(ROOT / "build" / "vimd"))
    args = ap.parse_args()
    dest = HERE / "alkane"
    if (dest / "conf.gro").exists() and not args.force:
        print("alkane: present (use --force)")
        return 0
    if not pathlib.Path(args.vimd).is_file():
        sys.exit(f"make_alkane.py: {args.vimd} not found (build vimd first, or pass --vimd)")
    with tempfile.TemporaryDirectory(prefix="make_alkane.") as tmp:
        work = pathlib.Path(tmp)
        gro, itp = decane_files()
        (work / "decane.gro").write_text(gro)
        (work / "decane.itp").write_text(itp)
        (work / "topol.top").write_text(TOPOLOGY)
        run(["gmx", "-quiet", "-nocopyright", "insert-molecules", "-ci", "decane.gro", "-nmol", MOLECULES,
             "-box", *[f"{BOX:.5f}"] * 3, "-seed", SEED, "-scale", INSERT_SCALE, "-try", 1000,
             "-o", "inserted.gro"], work, gmx_env())
        inserted = int((work / "inserted.gro").read_text().splitlines()[1])
        if inserted != MOLECULES * ATOMS:
            sys.exit(f"make_alkane.py: gmx insert-molecules placed {inserted} atoms, not all {MOLECULES} molecules")
        system = '[system]\nstructure = "{}"\ntopology = "topol.top"\nconstraints = "h-bonds"\n\n'
        minimised = vimd_run(args.vimd, work, "min", system.format("inserted.gro") + FORCEFIELD + """
[integrator]
type = "minimize"
emtol = 100.0
emstep = 0.01
steps = 5000

[output]
trajectory_every = 0
energy_every = 100
""")
        # The chains start all-trans: a hot stage lets them find gauche states before the 300 K one.
        for name, start, temperature, steps in (("hot", "out_min", HOT_TEMPERATURE, HOT_STEPS),
                                                ("nvt", "out_hot", TEMPERATURE, NVT_STEPS)):
            vimd_run(args.vimd, work, name, system.format(f"{start}/confout.gro") + FORCEFIELD + f"""
[integrator]
type = "rattle"
dt = 0.002
steps = {steps}
temperature = {temperature}
seed = {SEED % 1000}
thermostat = "v-rescale"
tau_t = 0.1

[output]
trajectory_every = 0
energy_every = 50
""")
        dest.mkdir(exist_ok=True)
        for name in ("decane.itp", "topol.top"):
            shutil.copy(work / name, dest / name)
        shutil.copy(work / "out_nvt" / "confout.gro", dest / "conf.gro")
        report(minimised, work / "out_nvt" / "energy.csv")
    print(f"alkane: {MOLECULES} n-decanes ({MOLECULES * ATOMS} atoms) in a {BOX:.5f} nm box")
    return 0


if __name__ == "__main__":
    sys.exit(main())

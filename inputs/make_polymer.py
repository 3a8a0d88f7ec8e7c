#!/usr/bin/python3
"""Generate the bead-spring polymer melt in inputs/polymer (conf.gro, topol.top, run.toml).

    /usr/bin/python3 inputs/make_polymer.py            # build unless inputs/polymer/conf.gro exists
    /usr/bin/python3 inputs/make_polymer.py --force    # rebuild

Model: Kremer-Grest-like melt of 100 chains x 50 beads with rigid bonds. Units are GROMACS units with
a MARTINI-sized coarse-grained bead:
  mass 72 amu (four heavy atoms), sigma 0.47 nm, epsilon = k_B * 300 K = 2.4943 kJ/mol, so 300 K is
  the usual Kremer-Grest reduced temperature T* = 1 and the LJ time unit is
  tau = sigma sqrt(m / epsilon) = 2.53 ps.
  Non-bonded: WCA, i.e. LJ cut at 2^(1/6) sigma = 0.52756 nm with potential-shift (purely repulsive).
  Bonds: rigid [ constraints ] of length 0.97 sigma = 0.4559 nm; bonded pairs are excluded (nrexcl 1),
  beads two apart along the chain interact through WCA.
  Angles: weak harmonic stiffness, theta0 = 180 deg, k = 5 kJ/mol/rad^2 (about 2 kT at 300 K).
  Density: 0.85 sigma^-3 = 8.19 beads/nm^3 (0.98 g/cm^3), cubic box of 8.484 nm.

Recipe (numpy only for the construction, seeded):
  1. grow each chain as a random walk of fixed step 0.97 sigma in the periodic box, rejecting any
     bead closer than 0.8 sigma to an existing bead (cell list, backtracking on dead ends);
  2. gmx_d steepest descent with the bonds as constraints removes the remaining WCA overlaps;
  3. gmx_d NVT md (leap-frog, LINCS, v-rescale at 300 K, 10 fs) gives relaxed packing and velocities;
     its final frame is conf.gro.
GROMACS steps run on one thread with -reprod and fixed seeds, so a rebuild reproduces the files.
Chain conformations come from step 1 plus a short relaxation: local structure is equilibrated, the
chains' large-scale shape (Rouse time ~ 10^3 tau for 50 beads) is not fully.
"""
import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

N_CHAINS = 100
N_BEADS = 50
MASS = 72.0                      # amu
SIGMA = 0.47                     # nm
KB = 0.0083144626                # kJ/mol/K
TEMPERATURE = 300.0              # K
EPSILON = KB * TEMPERATURE       # kJ/mol, T* = 1 at 300 K
WCA_CUTOFF = 2.0 ** (1.0 / 6.0) * SIGMA
BOND = 0.97 * SIGMA              # nm
ANGLE_THETA0 = 180.0             # degrees
ANGLE_K = 5.0                    # kJ/mol/rad^2
NUMBER_DENSITY = 0.85 / SIGMA**3  # beads/nm^3
MIN_DISTANCE = 0.8 * SIGMA       # closest approach allowed while growing chains
SEED = 20240607
MD_DT = 0.01                     # ps
MD_STEPS = 50000                 # 500 ps, ~200 tau

HERE = os.path.dirname(os.path.abspath(__file__))


class ChainGrower:
    """Random walks with excluded volume in a periodic cubic box, using a cell list."""

    def __init__(self, box, n_total, rng):
        self.box = box
        self.rng = rng
        self.n_cells = int(box // MIN_DISTANCE)
        self.cell_size = box / self.n_cells
        self.cells = {}
        self.pos = np.empty((n_total, 3))
        self.count = 0

    def _cell(self, x):
        return tuple((np.floor(x / self.cell_size).astype(int)) % self.n_cells)

    def _free(self, x):
        cx, cy, cz = self._cell(x)
        n = self.n_cells
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    members = self.cells.get(((cx + dx) % n, (cy + dy) % n, (cz + dz) % n))
                    if not members:
                        continue
                    d = self.pos[members] - x
                    d -= self.box * np.round(d / self.box)
                    if np.min(np.einsum("ij,ij->i", d, d)) < MIN_DISTANCE**2:
                        return False
        return True

    def _push(self, x):
        self.pos[self.count] = x
        self.cells.setdefault(self._cell(x), []).append(self.count)
        self.count += 1

    def _pop(self):
        self.count -= 1
        self.cells[self._cell(self.pos[self.count])].remove(self.count)

    def _random_direction(self):
        v = self.rng.normal(size=3)
        return v / np.linalg.norm(v)

    def grow_chain(self, n_beads, trials_per_bead=50, max_restarts=1000):
        first = self.count
        for _ in range(max_restarts):
            start = self.rng.uniform(0.0, self.box, size=3)
            if not self._free(start):
                continue
            self._push(start)
            dead_ends = 0
            while self.count - first < n_beads and dead_ends < 200:
                previous = self.pos[self.count - 1]
                for _ in range(trials_per_bead):
                    candidate = previous + BOND * self._random_direction()
                    if self._free(candidate):
                        self._push(candidate)
                        break
                else:
                    # dead end: back up a few beads (never past the first) and try again
                    dead_ends += 1
                    for _ in range(min(3, self.count - first - 1)):
                        self._pop()
            if self.count - first == n_beads:
                return
            while self.count > first:
                self._pop()
        sys.exit(f"make_polymer.py: could not place chain {first // n_beads + 1} "
                 f"after {max_restarts} restarts; lower MIN_DISTANCE or the density")


def write_gro(path, title, pos, box, decimals=5):
    width = decimals + 5
    with open(path, "w") as f:
        f.write(f"{title}\n{len(pos)}\n")
        for i, x in enumerate(pos):
            chain = i // N_BEADS + 1
            f.write(f"{chain % 100000:5d}{'PLY':<5s}{'B':>5s}{(i + 1) % 100000:5d}"
                    + "".join(f"{c:{width}.{decimals}f}" for c in x) + "\n")
        f.write(f"{box:10.5f}{box:10.5f}{box:10.5f}\n")


def write_topology(path):
    lines = [
        "; Bead-spring polymer melt (Kremer-Grest-like, rigid bonds), generated by inputs/make_polymer.py",
        f"; bead: {MASS:g} amu, sigma {SIGMA:g} nm, epsilon {EPSILON:.4f} kJ/mol (= k_B * 300 K);",
        f"; WCA = LJ cut at 2^(1/6) sigma = {WCA_CUTOFF:.5f} nm with potential-shift (set in the run file).",
        "",
        "[ defaults ]",
        "; nbfunc  comb-rule  gen-pairs  fudgeLJ  fudgeQQ",
        "  1       2          no         1.0      1.0",
        "",
        "[ atomtypes ]",
        "; name  mass     charge  ptype  sigma    epsilon",
        f"  BD    {MASS:.3f}   0.000   A      {SIGMA:.5f}  {EPSILON:.5f}",
        "",
        "[ moleculetype ]",
        "; name  nrexcl",
        "  PLY   1",
        "",
        "[ atoms ]",
        "; nr  type  resnr  residue  atom  cgnr  charge  mass",
    ]
    lines += [f"  {i:3d}  BD    1      PLY      B     {i:3d}   0.000   {MASS:.3f}"
              for i in range(1, N_BEADS + 1)]
    lines += ["", "[ constraints ]", ";  i    j  funct  length"]
    lines += [f"  {i:3d}  {i + 1:3d}  1      {BOND:.5f}" for i in range(1, N_BEADS)]
    lines += ["", "[ angles ]", ";  i    j    k  funct  theta0  k_theta"]
    lines += [f"  {i:3d}  {i + 1:3d}  {i + 2:3d}  1      {ANGLE_THETA0:.1f}   {ANGLE_K:.3f}"
              for i in range(1, N_BEADS - 1)]
    lines += ["", "[ system ]", f"Bead-spring polymer melt, {N_CHAINS} chains x {N_BEADS} beads",
              "", "[ molecules ]", f"PLY {N_CHAINS}", ""]
    with open(path, "w") as f:
        f.write("\n".join(lines))


# GROMACS's automatic Verlet buffer comes out as zero for WCA (the force vanishes at the cut-off) and
# the run then misses pairs; a fixed 0.1 nm buffer rebuilt every 10 steps is safe.
COMMON_MDP = f"""cutoff-scheme        = Verlet
verlet-buffer-tolerance = -1
rlist                = {WCA_CUTOFF + 0.1:.5f}
nstlist              = 10
coulombtype          = reaction-field   ; no charges; GROMACS's Verlet scheme needs rcoulomb = rvdw
rcoulomb             = {WCA_CUTOFF:.5f}
vdwtype              = cut-off
vdw-modifier         = potential-shift
rvdw                 = {WCA_CUTOFF:.5f}
DispCorr             = no
pbc                  = xyz
constraint-algorithm = lincs
lincs-order          = 8
lincs-iter           = 2
"""

EM_MDP = f"""integrator           = steep
emtol                = 10
emstep               = 0.001
nsteps               = 20000
{COMMON_MDP}"""

NVT_MDP = f"""integrator           = md
dt                   = {MD_DT}
nsteps               = {MD_STEPS}
nstcalcenergy        = 100
nstenergy            = 100
nstlog               = 5000
nstxout-compressed   = 0
{COMMON_MDP}tcoupl               = v-rescale
tc-grps              = System
tau_t                = 1.0
ref_t                = {TEMPERATURE:g}
pcoupl               = no
gen_vel              = yes
gen_temp             = {TEMPERATURE:g}
gen_seed             = {SEED}
ld_seed              = {SEED}
"""

RUN_TOML = f"""# Bead-spring polymer melt ({N_CHAINS} x {N_BEADS} beads), RATTLE on the rigid bonds.
# WCA: LJ cut at 2^(1/6) sigma with potential-shift; no charges.
[system]
structure = "conf.gro"
topology = "topol.top"

[forcefield]
cutoff = {WCA_CUTOFF:.5f}                  # nm, 2^(1/6) sigma
vdw_modifier = "potential-shift"   # none | potential-shift | force-switch | potential-switch
vdw_switch = 0.0                   # nm
coulomb = "none"                   # reaction-field | cutoff | none
epsilon_rf = 0.0                   # unused without charges
neighbor_skin = 0.1                # nm

[integrator]
type = "rattle"                    # verlet | shake | rattle | vi | rk
dt = {MD_DT}                          # ps (0.004 tau)
steps = 5000
constraint_tolerance = 1e-10

[output]
dir = "out"
trajectory_every = 100
energy_every = 10
"""


def run(cmd, log, cwd):
    with open(log, "a") as f:
        f.write("\n$ " + " ".join(cmd) + "\n")
        f.flush()
        done = subprocess.run(cmd, cwd=cwd, stdout=f, stderr=subprocess.STDOUT)
    if done.returncode != 0:
        with open(log) as f:
            tail = f.readlines()[-25:]
        sys.exit(f"make_polymer.py: '{' '.join(cmd)}' failed in {cwd}:\n" + "".join(tail))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--force", action="store_true", help="rebuild even if the output exists")
    parser.add_argument("--outdir", default=os.path.join(HERE, "polymer"))
    parser.add_argument("--gmx", default=os.environ.get("GMX_D", "gmx_d"),
                        help="double-precision GROMACS binary (default gmx_d, or $GMX_D)")
    args = parser.parse_args()

    if not args.force and os.path.exists(os.path.join(args.outdir, "conf.gro")):
        print(f"{args.outdir}/conf.gro present, skipped (use --force to rebuild)")
        return
    if shutil.which(args.gmx) is None:
        sys.exit(f"make_polymer.py: '{args.gmx}' not found (use --gmx or $GMX_D)")

    n_total = N_CHAINS * N_BEADS
    box = (n_total / NUMBER_DENSITY) ** (1.0 / 3.0)
    rng = np.random.default_rng(SEED)
    grower = ChainGrower(box, n_total, rng)
    for _ in range(N_CHAINS):
        grower.grow_chain(N_BEADS)
    print(f"grew {N_CHAINS} chains x {N_BEADS} beads in a {box:.4f} nm box "
          f"({n_total / box**3:.3f} beads/nm^3, {n_total * MASS * 1.66053907e-3 / box**3:.4f} g/cm^3)")

    work = tempfile.mkdtemp(prefix="make_polymer.")
    log = os.path.join(work, "gmx.log")
    write_gro(os.path.join(work, "start.gro"), "bead-spring melt, grown", grower.pos, box)
    write_topology(os.path.join(work, "topol.top"))
    for name, text in (("em.mdp", EM_MDP), ("nvt.mdp", NVT_MDP)):
        with open(os.path.join(work, name), "w") as f:
            f.write(text)
    gmx = [args.gmx, "-quiet", "-nocopyright"]
    run(gmx + ["grompp", "-f", "em.mdp", "-c", "start.gro", "-p", "topol.top", "-o", "em.tpr"], log, work)
    run(gmx + ["mdrun", "-deffnm", "em", "-nt", "1", "-reprod"], log, work)
    run(gmx + ["grompp", "-f", "nvt.mdp", "-c", "em.gro", "-p", "topol.top", "-o", "nvt.tpr"], log, work)
    run(gmx + ["mdrun", "-deffnm", "nvt", "-nt", "1", "-reprod", "-c", "conf.gro"], log, work)
    half_ps = MD_STEPS * MD_DT / 2
    energy = subprocess.run(gmx + ["energy", "-f", "nvt.edr", "-b", f"{half_ps:g}", "-o", "energy.xvg"],
                            cwd=work, input="Temperature\nPressure\nPotential\n\n", text=True,
                            capture_output=True)
    table = energy.stdout[energy.stdout.find("Energy "):] if "Energy " in energy.stdout else energy.stderr
    print(f"NVT averages over the last {half_ps:g} ps (gmx energy -b {half_ps:g}):\n{table.rstrip()}")

    os.makedirs(args.outdir, exist_ok=True)
    for name in ("conf.gro", "topol.top"):
        shutil.copy(os.path.join(work, name), os.path.join(args.outdir, name))
    with open(os.path.join(args.outdir, "run.toml"), "w") as f:
        f.write(RUN_TOML)
    shutil.rmtree(work)
    print(f"wrote {args.outdir}/conf.gro, topol.top, run.toml")


if __name__ == "__main__":
    main()

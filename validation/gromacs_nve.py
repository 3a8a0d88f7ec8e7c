#!/usr/bin/python3
"""NVE energy conservation of vimd RATTLE next to GROMACS double precision on the same input:
total-energy drift per atom (linear fit), the same drift over four blocks (a start transient or a
drift that comes and goes shows there), and RMS fluctuation, same analysis for both.
Water boxes: gmx_d md-vv with SETTLE, reaction field. `--system polymer`: the Kremer-Grest melt
(every bond rigid, WCA), gmx_d md with SHAKE 1e-8 (md-vv has no SHAKE), vimd at tolerance 1e-12;
its defaults are dt = 5 fs and 100 ps.
Usage: /usr/bin/python3 validation/gromacs_nve.py [--system water900|polymer] [--ps 20] [--dt 0.002]
"""
import argparse
import json
import pathlib
import sys
import tempfile

import numpy as np

from gmx_common import ROOT, run, write_mdp, nonbonded_mdp, gmx_energy, vimd_config, vimd, read_xvg


def statistics(t, e, atoms):
    """Drift (kJ/mol/ps per atom, slope of a linear fit) and RMS fluctuation about the mean."""
    t, e = np.asarray(t), np.asarray(e)
    slope = np.polyfit(t, e, 1)[0]
    return slope / atoms, float(np.sqrt(np.mean((e - e.mean()) ** 2)))


def block_drifts(t, e, atoms, blocks=4):
    t, e = np.asarray(t), np.asarray(e)
    m = len(t) // blocks
    return [np.polyfit(t[k * m:(k + 1) * m], e[k * m:(k + 1) * m], 1)[0] / atoms for k in range(blocks)]


# Per system: vimd [forcefield], GROMACS settings, vimd constraint tolerance, default dt and length.
WATER = dict(ff=dict(cutoff=0.9, vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="reaction-field", epsilon_rf=0),
             gmx=dict(integrator="md-vv", constraints="none", **nonbonded_mdp(0.9, "potential-shift", 0.0, 0, rlist=1.0)),
             tolerance=1e-10, dt=0.002, ps=20.0,
             label="potential-shift LJ + RF (eps_rf = inf), cut-off 0.9 nm; gmx_d md-vv + SETTLE")
POLYMER_CUTOFF = 0.52756  # 2^(1/6) sigma: WCA
POLYMER = dict(ff=dict(cutoff=POLYMER_CUTOFF, vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="none"),
               gmx=dict(integrator="md", constraints="all-bonds", constraint_algorithm="shake", shake_tol=1e-8,
                        **nonbonded_mdp(POLYMER_CUTOFF, "potential-shift", 0.0, 0, coulomb="cutoff",
                                        rlist=POLYMER_CUTOFF + 0.1)),
               tolerance=1e-12, dt=0.005, ps=100.0,
               label="WCA (LJ potential-shift at 2^(1/6) sigma), rigid bonds; gmx_d md + SHAKE 1e-8")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--system", default="water900")
    ap.add_argument("--ps", type=float, help="length (default: 20 ps for water, 100 ps for the polymer)")
    ap.add_argument("--dt", type=float, help="time step (default: 0.002 ps for water, 0.005 ps for the polymer)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--keep", help="directory to keep the runs in (default: temporary)")
    args = ap.parse_args()
    src = ROOT / "inputs" / args.system
    setup = POLYMER if args.system == "polymer" else WATER
    args.dt = args.dt or setup["dt"]
    args.ps = args.ps or setup["ps"]
    steps = int(round(args.ps / args.dt))

    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(args.keep or tmp)
        work.mkdir(parents=True, exist_ok=True)
        write_mdp(work / "nve.mdp", dt=args.dt, nsteps=steps, nstcalcenergy=10, nstenergy=10,
                  nstlog=1000, comm_mode="None", tcoupl="no", pcoupl="no", gen_vel="no", continuation="no",
                  **setup["gmx"])
        run(["gmx_d", "grompp", "-f", "nve.mdp", "-c", src / "conf.gro", "-p", src / "topol.top", "-o", "nve.tpr", "-maxwarn", "2"], work)
        run(["gmx_d", "mdrun", "-s", "nve.tpr", "-deffnm", "gmx_nve", "-nt", str(args.threads), "-pin", "off"], work)
        g = gmx_energy("gmx_d", "gmx_nve.edr", ["Total-Energy"], work)
        atoms = int((src / "conf.gro").read_text().splitlines()[1])
        gmx_drift, gmx_fluct = statistics(g["time"], g["Total Energy"], atoms)
        gmx_blocks = block_drifts(g["time"], g["Total Energy"], atoms)

        vimd_config(work / "nve.toml", src / "conf.gro", src / "topol.top", setup["ff"],
                    dict(type="rattle", dt=args.dt, steps=steps, constraint_tolerance=setup["tolerance"]),
                    dict(dir=str(work / "vimd"), trajectory_every=0, energy_every=10))
        vimd("run", work / "nve.toml", threads=args.threads)
        summary = json.loads((work / "vimd" / "summary.json").read_text())
        legends, cols = read_xvg(work / "vimd" / "energy.xvg")
        v_drift, v_fluct = statistics(cols[0], cols[1 + legends.index("total")], atoms)
        v_blocks = block_drifts(cols[0], cols[1 + legends.index("total")], atoms)

    print(f"NVE, {args.system} ({atoms} atoms), dt = {args.dt} ps, {args.ps} ps, {setup['label']}")
    print(f"{'engine':<28}{'drift kJ/mol/ps/atom':>22}{'RMS fluct. kJ/mol':>20}   drift in 4 blocks")
    print(f"{'vimd rattle (summary)':<28}{summary['drift_per_atom']:>22.3e}{summary['rms_fluctuation']:>20.4e}")
    for name, drift, fluct, blocks in (("vimd rattle (this script)", v_drift, v_fluct, v_blocks),
                                       (f"gmx_d {setup['gmx']['integrator']}", gmx_drift, gmx_fluct, gmx_blocks)):
        print(f"{name:<28}{drift:>22.3e}{fluct:>20.4e}   " + " ".join(f"{b:+.1e}" for b in blocks))
    return 0


if __name__ == "__main__":
    sys.exit(main())

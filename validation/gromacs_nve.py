#!/usr/bin/python3
"""NVE energy conservation of vimd RATTLE next to GROMACS (gmx_d, md-vv with SETTLE) on the same
water box: total-energy drift per atom (linear fit) and RMS fluctuation, same analysis for both.
Usage: /usr/bin/python3 validation/gromacs_nve.py [--system water900] [--ps 20] [--dt 0.002]
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--system", default="water900")
    ap.add_argument("--ps", type=float, default=20.0)
    ap.add_argument("--dt", type=float, default=0.002)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--keep", help="directory to keep the runs in (default: temporary)")
    args = ap.parse_args()
    src = ROOT / "inputs" / args.system
    steps = int(round(args.ps / args.dt))
    ff = dict(cutoff=0.9, vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="reaction-field", epsilon_rf=0)

    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(args.keep or tmp)
        work.mkdir(parents=True, exist_ok=True)
        write_mdp(work / "nve.mdp", integrator="md-vv", dt=args.dt, nsteps=steps, nstcalcenergy=10, nstenergy=10,
                  nstlog=1000, comm_mode="None", tcoupl="no", pcoupl="no", gen_vel="no", continuation="no",
                  constraints="none", **nonbonded_mdp(0.9, "potential-shift", 0.0, 0, rlist=1.0))
        run(["gmx_d", "grompp", "-f", "nve.mdp", "-c", src / "conf.gro", "-p", src / "topol.top", "-o", "nve.tpr", "-maxwarn", "2"], work)
        run(["gmx_d", "mdrun", "-s", "nve.tpr", "-deffnm", "gmx_nve", "-nt", str(args.threads), "-pin", "off"], work)
        g = gmx_energy("gmx_d", "gmx_nve.edr", ["Total-Energy"], work)
        atoms = int((src / "conf.gro").read_text().splitlines()[1])
        gmx_drift, gmx_fluct = statistics(g["time"], g["Total Energy"], atoms)

        vimd_config(work / "nve.toml", src / "conf.gro", src / "topol.top", ff,
                    dict(type="rattle", dt=args.dt, steps=steps, constraint_tolerance=1e-10),
                    dict(dir=str(work / "vimd"), trajectory_every=0, energy_every=10))
        vimd("run", work / "nve.toml", threads=args.threads)
        summary = json.loads((work / "vimd" / "summary.json").read_text())
        legends, cols = read_xvg(work / "vimd" / "energy.xvg")
        v_drift, v_fluct = statistics(cols[0], cols[1 + legends.index("total")], atoms)

    print(f"NVE, {args.system} ({atoms} atoms), dt = {args.dt} ps, {args.ps} ps, potential-shift LJ + RF (eps_rf = inf), cut-off 0.9 nm")
    print(f"{'engine':<28}{'drift kJ/mol/ps/atom':>22}{'RMS fluct. kJ/mol':>20}")
    print(f"{'vimd rattle (summary)':<28}{summary['drift_per_atom']:>22.3e}{summary['rms_fluctuation']:>20.4e}")
    print(f"{'vimd rattle (this script)':<28}{v_drift:>22.3e}{v_fluct:>20.4e}")
    print(f"{'gmx_d md-vv + SETTLE':<28}{gmx_drift:>22.3e}{gmx_fluct:>20.4e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

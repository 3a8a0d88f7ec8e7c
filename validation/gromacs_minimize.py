#!/usr/bin/python3
"""Steepest descent of vimd (type = "minimize") next to GROMACS's `steep` on the same input.

Runs both on inputs/tip3p_solvated (the raw `gmx solvate -cs spc216 -box 2.6 2.6 2.6` TIP3P box,
molecules overlapping at the periodic seams) with the same interactions (reaction field
eps_rf = infinity, rvdw = rcoulomb = 0.9 nm, LJ potential-shift), rigid water (SETTLE in GROMACS,
three distance constraints in vimd), the same emtol, emstep and step limit, and prints the start
and final potentials, LJ + Coulomb, the largest force with its atom and the steps taken.
Minimisers stop at different local minima, so the potentials are compared, not asserted equal.
Usage: /usr/bin/python3 validation/gromacs_minimize.py [--emtol 100] [--gmx gmx_d]
"""
import argparse
import json
import pathlib
import re
import sys
import tempfile

from gmx_common import ROOT, run, write_mdp, nonbonded_mdp, gmx_energy, vimd

SRC = ROOT / "inputs" / "tip3p_solvated"


def gromacs_steep(gmx, emtol, nsteps, work):
    work.mkdir(parents=True, exist_ok=True)
    # Pair list with a 0.1 nm buffer, rebuilt every step: exact interactions in every trial.
    mdp = nonbonded_mdp(0.9, "potential-shift", 0.0, 0, rlist=1.0)
    mdp["nstlist"] = 1
    write_mdp(work / "em.mdp", integrator="steep", emtol=emtol, emstep=0.01, nsteps=nsteps, **mdp)
    run([gmx, "grompp", "-f", "em.mdp", "-c", SRC / "conf.gro", "-p", SRC / "topol.top", "-o", "em.tpr",
         "-maxwarn", "1"], work)
    run([gmx, "mdrun", "-deffnm", "em", "-nt", "1"], work)
    log = (work / "em.log").read_text()
    fmax = re.search(r"Maximum force\s+=\s+(\S+) on atom (\d+)", log)
    steps = re.search(r"(?:converged to Fmax < \S+|did not converge to Fmax < \S+) in (\d+) steps", log)
    e = gmx_energy(gmx, "em.edr", ["LJ-(SR)", "Coulomb-(SR)", "Potential"], work)
    return dict(start=e["Potential"][0], potential=e["Potential"][-1], lj=e["LJ (SR)"][-1],
                coulomb=e["Coulomb (SR)"][-1], max_force=float(fmax.group(1)), atom=int(fmax.group(2)),
                steps=int(steps.group(1)) if steps else None)


def vimd_minimize(emtol, nsteps, work):
    out = work / "vimd"
    text = (SRC / "run_min.toml").read_text()
    text = re.sub(r"(?m)^emtol = .*$", f"emtol = {emtol}", text)
    text = re.sub(r"(?m)^steps = .*$", f"steps = {nsteps}", text)
    for name in ("conf.gro", "topol.top"):
        text = text.replace(f'"{name}"', json.dumps(str(SRC / name)))
    (work / "run_min.toml").write_text(text)
    vimd("run", work / "run_min.toml", "--out", out)
    s = json.loads((out / "summary.json").read_text())
    start = json.loads(vimd("energy", work / "run_min.toml", "--json"))["potential"]
    return dict(start=start, potential=s["potential"], lj=s["lj"], coulomb=s["coulomb"], max_force=s["max_force"],
                atom=s["max_force_atom"], steps=s["steps"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--emtol", type=float, default=100.0)
    ap.add_argument("--steps", type=int, default=5000)
    ap.add_argument("--gmx", default="gmx_d")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(tmp)
        v = vimd_minimize(args.emtol, args.steps, work)
        g = gromacs_steep(args.gmx, args.emtol, args.steps, work / "gmx")
    print(f"TIP3P box {SRC.relative_to(ROOT)}, emtol {args.emtol:g} kJ/mol/nm, emstep 0.01 nm, at most {args.steps} steps")
    print(f"{'':<16} {'start V':>14} {'final V':>14} {'LJ':>12} {'Coulomb':>14} {'LJ+Coulomb':>14} {'max force':>10} {'atom':>6} {'steps':>6}")
    for name, r in ((f"{args.gmx} steep", g), ("vimd minimize", v)):
        print(f"{name:<16} {r['start']:>14.2f} {r['potential']:>14.2f} {r['lj']:>12.2f} {r['coulomb']:>14.2f} "
              f"{r['lj'] + r['coulomb']:>14.2f} {r['max_force']:>10.2f} {r['atom']:>6} {r['steps'] or '?':>6}")
    print(f"final potential difference vimd - GROMACS: {v['potential'] - g['potential']:+.2f} kJ/mol "
          f"({(v['potential'] - g['potential']) / abs(g['potential']):+.2%})")
    return 0


if __name__ == "__main__":
    sys.exit(main())

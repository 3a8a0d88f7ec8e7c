#!/usr/bin/python3
"""The whole preparation protocol of the raw TIP3P box, in vimd and in GROMACS (gmx_d), side by side.

On inputs/tip3p_solvated (`gmx solvate -cs spc216 -box 2.6 2.6 2.6`, 578 TIP3P waters overlapping at
the periodic seams), each engine, with the same interactions (reaction field eps_rf = infinity,
rvdw = rcoulomb = 0.9 nm, LJ potential-shift) and rigid water (vimd: constraints; GROMACS: SETTLE):
  1. minimises: vimd run_min.toml (steepest descent) / gmx steep, emtol 100 kJ/mol/nm, emstep 0.01 nm;
  2. equilibrates 20 ps at 300 K from its own minimised structure, velocities generated at 300 K,
     v-rescale thermostat with tau_t 0.1 ps, 2 fs: vimd run_nvt.toml (RATTLE) / gmx md (leap-frog);
  3. runs 10 ps NVE at 2 fs from its own equilibrated state: vimd run_nve.toml (RATTLE) and the same
     with type = "vi", method = "rk4", bias = [0, 1] (default
     tolerances) / gmx md (leap-frog) and gmx md-vv (velocity Verlet).
and prints the final figures of each stage in one table per stage, then every command it ran.

The engines' trajectories diverge chaotically within picoseconds (and the two thermostats draw
different random numbers), so only ensemble figures are compared: means, fluctuations and drifts,
never trajectories or instantaneous values. Minimisers end in different local minima, so their
potentials are comparable, not equal. The NVE runs start from different equilibrated states, so their
mean energies differ by about the canonical spread of the total energy (printed with the NVT figures);
the two vimd NVE runs start from the same state and must agree with each other. vimd continues from
its confout.gro (.gro precision, re-constrained by the engine), GROMACS from nvt.cpt (exact). With LJ
potential-shift the force jumps at the cut-off, so vi rk4's higher order does not carry over to its
long-time energy error here (inputs/water900/run_vi.toml switches LJ and Coulomb for that reason).
Drift = slope of a linear fit of the conserved energy (vimd `conserved` column, GROMACS "Conserved
En."; in NVE the total energy), per atom; RMS fluctuation = about the mean; both from the energy files
(every 10 steps) with the same code for both engines. Everything runs on one thread.
Usage: /usr/bin/python3 validation/gromacs_protocol.py [--quick] [--work DIR] [--gmx gmx_d]
"""
import argparse
import json
import os
import pathlib
import re
import shutil
import sys
import time

import numpy as np

import gmx_common
from gmx_common import ROOT, run, write_mdp, nonbonded_mdp, gmx_energy, read_xvg, vimd
from gromacs_minimize import gromacs_steep
from gromacs_nve import statistics

SRC = ROOT / "inputs" / "tip3p_solvated"
KB = 0.0083144626  # kJ/mol/K
DT = 0.002         # ps, the run files' time step


def block_error(x, blocks=10):
    """Standard error of the mean of a correlated series from the scatter of block means."""
    means = [b.mean() for b in np.array_split(np.asarray(x), blocks)]
    return float(np.std(means, ddof=1) / np.sqrt(blocks))


def series_stats(t, terms, atoms, ndf, temperature=None):
    """The figures of one MD run from its energy series (dict with potential, kinetic, total,
    conserved, temperature): means, drift and fluctuation of the conserved energy; with a reference
    temperature (NVT), the means and the kinetic-energy spread are over the second half only."""
    t = np.asarray(t)
    half = t >= (t[0] + t[-1]) / 2 if temperature else np.ones_like(t, dtype=bool)
    drift, fluct = statistics(t, terms["conserved"], atoms)
    s = {k: float(np.mean(np.asarray(v)[half])) for k, v in terms.items()}
    s.update(drift=drift, fluct=fluct, T_err=block_error(np.asarray(terms["temperature"])[half]),
             E_std=float(np.std(np.asarray(terms["total"])[half])))
    if temperature:
        s["K_std_ratio"] = float(np.std(np.asarray(terms["kinetic"])[half])) / (np.sqrt(ndf / 2) * KB * temperature)
    return s


def vimd_series(out):
    legends, cols = read_xvg(out / "energy.xvg")
    col = {name: np.asarray(cols[1 + legends.index(name)]) for name in
           ("potential", "kinetic", "total", "conserved", "temperature")}
    return cols[0], col


def gmx_series(gmx, edr, work, thermostat):
    names = {"potential": "Potential", "kinetic": "Kinetic En.", "total": "Total Energy", "temperature": "Temperature"}
    if thermostat:  # without one GROMACS writes no "Conserved En.": it is the total energy
        names["conserved"] = "Conserved En."
    e = gmx_energy(gmx, edr, [n.replace(" ", "-") for n in names.values()], work)
    series = {k: np.asarray(e[n]) for k, n in names.items()}
    return e["time"], {"conserved": series["total"]} | series


def run_vimd(*args):
    vimd("--threads", 1, *args, threads=1)


def vimd_protocol(work, nvt_steps, nve_steps):
    """The three stages with the repository's run files, copied next to the inputs into work (their
    paths are relative to the file: out_min, out_nvt, out_nve, out_nve_vi)."""
    for name in ("conf.gro", "topol.top", "run_min.toml", "run_nvt.toml", "run_nve.toml"):
        shutil.copy(SRC / name, work / name)
    vi = (SRC / "run_nve.toml").read_text()
    vi = re.sub(r'(?m)^type = "rattle".*$', 'type = "vi"\nmethod = "rk4"\nbias = [0.0, 1.0]', vi)
    vi = re.sub(r'(?m)^dir = "out_nve"', 'dir = "out_nve_vi"', vi)
    (work / "run_nve_vi.toml").write_text(vi)
    run_vimd("run", work / "run_min.toml", "--overwrite")
    run_vimd("run", work / "run_nvt.toml", "--overwrite", "--steps", nvt_steps)
    for name in ("run_nve.toml", "run_nve_vi.toml"):
        run_vimd("run", work / name, "--overwrite", "--steps", nve_steps)
    em = json.loads((work / "out_min" / "summary.json").read_text())
    return em | {"atom": em["max_force_atom"]}


def gromacs_protocol(gmx, work, nvt_steps, nve_steps):
    """steep (as validation/gromacs_minimize.py), then md + v-rescale, then md and md-vv."""
    em = gromacs_steep(gmx, 100.0, 5000, work)
    md = dict(dt=DT, nstcalcenergy=10, nstenergy=10, nstlog=1000, comm_mode="Linear", nstcomm=100,
              pcoupl="no", **nonbonded_mdp(0.9, "potential-shift", 0.0, 0, rlist=1.0))
    # Fixed seeds (velocities and the thermostat's noise, as seed = 1 in run_nvt.toml): reruns repeat exactly.
    write_mdp(work / "nvt.mdp", integrator="md", nsteps=nvt_steps, tcoupl="v-rescale", tc_grps="System",
              tau_t=0.1, ref_t=300, gen_vel="yes", gen_temp=300, gen_seed=1, ld_seed=1, continuation="no",
              **md)
    run([gmx, "grompp", "-f", "nvt.mdp", "-c", "em.gro", "-p", SRC / "topol.top", "-o", "nvt.tpr"], work)
    run([gmx, "mdrun", "-deffnm", "nvt", "-nt", "1", "-pin", "off"], work)
    runs = {}
    for integrator in ("md", "md-vv"):
        name = f"nve_{integrator.replace('-', '')}"
        write_mdp(work / f"{name}.mdp", integrator=integrator, nsteps=nve_steps, tcoupl="no", gen_vel="no",
                  continuation="yes", **md)
        run([gmx, "grompp", "-f", f"{name}.mdp", "-c", "nvt.gro", "-t", "nvt.cpt", "-p", SRC / "topol.top",
             "-o", f"{name}.tpr"], work)
        run([gmx, "mdrun", "-deffnm", name, "-nt", "1", "-pin", "off"], work)
        runs[integrator] = gmx_series(gmx, f"{name}.edr", work, thermostat=False)
    return em, gmx_series(gmx, "nvt.edr", work, thermostat=True), runs


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2 ps NVT and 1 ps NVE (a smoke test of the script)")
    ap.add_argument("--work", type=pathlib.Path, default=ROOT / "build" / "gromacs_protocol",
                    help="directory for the runs, kept for inspection (default: build/gromacs_protocol)")
    ap.add_argument("--gmx", default="gmx_d")
    args = ap.parse_args()
    nvt_steps, nve_steps = (1000, 500) if args.quick else (10000, 5000)
    work = args.work.resolve()
    (work / "gmx").mkdir(parents=True, exist_ok=True)
    os.environ["GMX_MAXBACKUP"] = "-1"  # rerunning overwrites instead of piling up #backups#

    atoms = int((SRC / "conf.gro").read_text().splitlines()[1])
    ndf = 3 * atoms - atoms - 3  # rigid 3-site water: 3 constraints per molecule; total momentum fixed

    start = time.monotonic()
    vmin = vimd_protocol(work, nvt_steps, nve_steps)
    gmin, gnvt, gnve = gromacs_protocol(args.gmx, work / "gmx", nvt_steps, nve_steps)
    wall = time.monotonic() - start

    vnvt = series_stats(*vimd_series(work / "out_nvt"), atoms, ndf, 300.0)
    gnvt = series_stats(*gnvt, atoms, ndf, 300.0)
    nve = {"vimd rattle": series_stats(*vimd_series(work / "out_nve"), atoms, ndf),
           "vimd vi rk4 [0,1]": series_stats(*vimd_series(work / "out_nve_vi"), atoms, ndf),
           f"{args.gmx} md (leap-frog)": series_stats(*gnve["md"], atoms, ndf),
           f"{args.gmx} md-vv": series_stats(*gnve["md-vv"], atoms, ndf)}

    print(f"TIP3P box {SRC.relative_to(ROOT)}: {atoms} atoms, {ndf} degrees of freedom; RF eps_rf = inf, "
          f"cut-off 0.9 nm, LJ potential-shift; one thread")
    print("\n1. Minimisation (steepest descent, emtol 100 kJ/mol/nm, emstep 0.01 nm, at most 5000 steps)")
    print(f"{'':<24}{'final V kJ/mol':>16}{'LJ+Coul kJ/mol':>16}{'max force':>11}{'atom':>6}{'steps':>7}")
    for name, r in ((f"{args.gmx} steep", gmin), ("vimd minimize", vmin)):
        print(f"{name:<24}{r['potential']:>16.2f}{r['lj'] + r['coulomb']:>16.2f}{r['max_force']:>11.2f}"
              f"{r['atom']:>6}{r['steps'] or '?':>7}")

    ps = nvt_steps * DT
    print(f"\n2. Equilibration, {ps:g} ps at 300 K, v-rescale tau_t 0.1 ps, dt {DT} ps; means over the second half"
          f" (T ± block standard error); sigma(K) / canonical sqrt(Ndf/2) kT; drift and fluctuation of the"
          f" conserved energy over the whole run")
    print(f"{'':<24}{'<T> K':>15}{'<V> kJ/mol':>13}{'sigma(K)/can.':>14}{'sigma(E) kJ/mol':>16}"
          f"{'drift kJ/mol/ps/atom':>22}{'RMS fluct.':>12}")
    for name, s in ((f"{args.gmx} md + v-rescale", gnvt), ("vimd rattle + v-rescale", vnvt)):
        print(f"{name:<24}{s['temperature']:>9.2f} ±{s['T_err']:>4.2f}{s['potential']:>13.1f}{s['K_std_ratio']:>14.3f}"
              f"{s['E_std']:>16.1f}{s['drift']:>22.3e}{s['fluct']:>12.3f}")

    print(f"\n3. NVE, {nve_steps * DT:g} ps at {DT} ps from each engine's own equilibrated state "
          f"(drift and RMS fluctuation of the total energy)")
    print(f"{'':<24}{'<V> kJ/mol':>13}{'<E> kJ/mol':>13}{'<T> K':>15}{'drift kJ/mol/ps/atom':>22}{'RMS fluct.':>12}")
    for name, s in nve.items():
        print(f"{name:<24}{s['potential']:>13.1f}{s['total']:>13.1f}{s['temperature']:>9.2f} ±{s['T_err']:>4.2f}"
              f"{s['drift']:>22.3e}{s['fluct']:>12.4f}")

    print(f"\nCommands (work directory {work}, kept: run files, .mdp files and outputs; "
          f"run_nve_vi.toml is run_nve.toml with type = \"vi\", method = \"rk4\", bias = [0.0, 1.0], dir = \"out_nve_vi\"):")
    print(f"cp {' '.join(str(SRC / n) for n in ('conf.gro', 'topol.top', 'run_min.toml', 'run_nvt.toml', 'run_nve.toml'))} {work}/")
    for cwd, line, seconds in gmx_common.HISTORY:
        if " energy " in line:
            continue  # the analysis reads the .edr files with gmx energy
        print((f"(cd {cwd} && {line})" if cwd else f"OMP_NUM_THREADS=1 {line}") + f"    # {seconds:.1f} s")
    print(f"wall time of the protocol: {wall:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""NVE energy conservation of vimd RATTLE next to GROMACS double precision on the same input:
total-energy drift per atom (linear fit), the same drift over four blocks (a start transient or a
drift that comes and goes shows there), and RMS fluctuation, same analysis for both.
Water boxes: gmx_d md-vv with SETTLE, reaction field (`--coulomb pme`: PME at GROMACS's defaults). `--system polymer`: the Kremer-Grest melt
(every bond rigid, WCA), gmx_d md with SHAKE 1e-8 (md-vv has no SHAKE), vimd at tolerance 1e-12;
its defaults are dt = 5 fs and 100 ps; `--gmx-vv` runs GROMACS's velocity Verlet instead (md-vv, with
LINCS of order 12 and 4 iterations: the integrator of vimd's RATTLE, with another constraint solver).
`--system alkane`: the OPLS-AA n-decane melt with its C-H bonds rigid (constraints = h-bonds), reaction
field as its run.toml; gmx_d md-vv with LINCS of order 8 and 4 iterations (GROMACS's SHAKE has been seen
to stop on OPLS-AA alkane melts with a range-check error), 10 ps at 2 fs by default.
A single run's drift is mostly its random walk; `--seeds N` gives each engine N independent starts.
`--precision mixed`: vimd with `precision = "mixed"` (single-precision pair forces) against GROMACS in
mixed precision (`gmx`, or the build given by `--gmx`, e.g. one built for this CPU).
`--results FILE` also writes the comparison's row to a results file (replaced), for validation/tables.py.
Usage: /usr/bin/python3 validation/gromacs_nve.py [--system water900|polymer|alkane] [--coulomb reaction-field|pme]
                                                  [--ps 20] [--dt 0.002] [--gmx-vv] [--seeds N]
                                                  [--precision double|mixed] [--gmx PATH]
                                                  [--results validation/results/NAME.json]
"""
import argparse
import json
import pathlib
import sys
import tempfile

import numpy as np

from gmx_common import (ROOT, gmx_energy, gmx_simd, nonbonded_mdp, read_xvg, results_start, run, sci, vimd,
                        vimd_config, write_mdp, write_results)


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
PME_WATER = dict(ff=dict(cutoff=1.0, vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="pme", ewald_rtol=1e-5,
                         pme_order=4, fourier_spacing=0.12),
                 gmx=dict(integrator="md-vv", constraints="none",
                          **nonbonded_mdp(1.0, "potential-shift", 0.0, 0, coulomb="pme", rlist=1.1,
                                          pme=dict(ewald_rtol=1e-5, pme_order=4, fourier_spacing=0.12))),
                 tolerance=1e-10, dt=0.002, ps=20.0,
                 label="potential-shift LJ + PME (GROMACS's defaults), cut-off 1.0 nm; gmx_d md-vv + SETTLE")
POLYMER_CUTOFF = 0.52756  # 2^(1/6) sigma: WCA
POLYMER = dict(ff=dict(cutoff=POLYMER_CUTOFF, vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="none"),
               gmx=dict(integrator="md", constraints="all-bonds", constraint_algorithm="shake", shake_tol=1e-8,
                        **nonbonded_mdp(POLYMER_CUTOFF, "potential-shift", 0.0, 0, coulomb="cutoff",
                                        rlist=POLYMER_CUTOFF + 0.1)),
               tolerance=1e-12, dt=0.005, ps=100.0,
               label="WCA (LJ potential-shift at 2^(1/6) sigma), rigid bonds; gmx_d md + SHAKE 1e-8")


ALKANE = dict(ff=WATER["ff"], system=dict(constraints="h-bonds"),
              gmx=dict(integrator="md-vv", constraints="h-bonds", constraint_algorithm="lincs", lincs_order=8,
                       lincs_iter=4, **nonbonded_mdp(0.9, "potential-shift", 0.0, 0, rlist=1.0)),
              tolerance=1e-10, dt=0.002, ps=10.0,
              label="potential-shift LJ + RF (eps_rf = inf), cut-off 0.9 nm, C-H bonds rigid; gmx_d md-vv + LINCS 8/4")
SETUPS = dict(polymer=POLYMER, alkane=ALKANE)
# The results file's columns: one row per comparison.
COLUMNS = ["run", "vimd drift (kJ/mol/ps/atom)", "GROMACS drift", "drift z", "vimd RMS fluct. (kJ/mol)",
           "GROMACS RMS fluct.", "fluct. z"]


def save_results(args, record, gmx_name, starts, v, g, z=None, notes=""):
    """Replace the results file with this comparison: v and g hold (drift, fluct, SIMD), drift and
    fluct as numbers for one start or as (mean, standard error) pairs for several; z the two
    differences' z-scores."""
    def text(x, drift):
        if isinstance(x, tuple):
            return f"{sci(x[0], 2, sign=True)} ± {sci(x[1], 1)}" if drift else f"{x[0]:.3g} ± {x[1]:.2g}"
        return sci(x, 3, sign=True) if drift else f"{x:.3g}"
    system = args.system if args.system in SETUPS else f"{args.system} {'PME' if args.coulomb == 'pme' else 'RF'}"
    run_label = (f"{system}, {args.precision}, {args.dt * 1e3:g} fs, {args.ps:g} ps, "
                 f"{starts} start{'s' if starts > 1 else ''}; {gmx_name}")
    zs = [f"{x:+.2f}" for x in z] if z else ["", ""]
    cells = [run_label, text(v[0], True), text(g[0], True), zs[0], text(v[1], False), text(g[1], False), zs[1]]
    record.update(simd=f"vimd {v[2]}; {pathlib.Path(args.gmx).name} {g[2]}", columns=COLUMNS,
                  rows=[dict(zip(COLUMNS, cells))], notes=f"{args.threads} threads. {notes}".strip())
    write_results(args.results, record)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--system", default="water900")
    ap.add_argument("--coulomb", default="reaction-field", choices=["reaction-field", "pme"], help="water boxes only")
    ap.add_argument("--ps", type=float, help="length (default: 20 ps for water, 100 ps for the polymer)")
    ap.add_argument("--dt", type=float, help="time step (default: 0.002 ps for water, 0.005 ps for the polymer)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--keep", help="directory to keep the runs in (default: temporary)")
    ap.add_argument("--seeds", type=int, default=0,
                    help="N independent starts (velocities drawn at 300 K by each engine) instead of conf.gro's: "
                         "mean drift and its standard error per engine")
    ap.add_argument("--gmx-vv", action="store_true",
                    help="polymer: GROMACS md-vv with LINCS (order 12, 4 iterations) instead of md with SHAKE")
    ap.add_argument("--precision", default="double", choices=["double", "mixed"])
    ap.add_argument("--gmx", help="the GROMACS to compare with (default: gmx_d, or gmx with --precision mixed)")
    ap.add_argument("--results", type=pathlib.Path, help="also write the comparison to this results file (replaced)")
    args = ap.parse_args()
    record = results_start("nve") if args.results else None
    args.gmx = args.gmx or ("gmx" if args.precision == "mixed" else "gmx_d")
    src = ROOT / "inputs" / args.system
    setup = SETUPS.get(args.system, PME_WATER if args.coulomb == "pme" else WATER)
    if args.gmx_vv and setup is POLYMER:
        gmx = {k: v for k, v in POLYMER["gmx"].items() if k != "shake_tol"}
        gmx.update(integrator="md-vv", constraint_algorithm="lincs", lincs_order=12, lincs_iter=4)
        setup = POLYMER | dict(gmx=gmx, label=POLYMER["label"].replace("md + SHAKE 1e-8", "md-vv + LINCS 12/4"))
    args.dt = args.dt or setup["dt"]
    args.ps = args.ps or setup["ps"]
    atoms = int((src / "conf.gro").read_text().splitlines()[1])
    gmx_name = f"{pathlib.Path(args.gmx).name} {setup['gmx']['integrator']}"
    if args.precision == "mixed":
        setup = setup | dict(ff=setup["ff"] | dict(precision="mixed"))
    label = setup["label"].replace("gmx_d", pathlib.Path(args.gmx).name)
    print(f"NVE, {args.system} ({atoms} atoms), dt = {args.dt} ps, {args.ps} ps, {label}; "
          f"{args.precision} precision: vimd against {args.gmx}")
    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(args.keep or tmp)
        if not args.seeds:
            v, g = run_both(work, src, src / "conf.gro", setup, args, atoms, seed=None)
            print(f"{'engine':<28}{'drift kJ/mol/ps/atom':>22}{'RMS fluct. kJ/mol':>20}   drift in 4 blocks")
            print(f"{'vimd rattle (summary)':<28}{v['summary_drift']:>22.3e}{v['summary_rms']:>20.4e}")
            for name, r in (("vimd rattle (this script)", v), (gmx_name, g)):
                print(f"{name:<28}{r['drift']:>22.3e}{r['fluct']:>20.4e}   " + " ".join(f"{b:+.1e}" for b in r["blocks"]))
            if record:
                blocks = "; ".join(f"{name} drift in 4 blocks " + ", ".join(sci(b, 1, sign=True) for b in r["blocks"])
                                   for name, r in (("vimd", v), (gmx_name, g)))
                save_results(args, record, gmx_name, 1, *((r["drift"], r["fluct"], r["simd"]) for r in (v, g)),
                             notes=blocks)
            return 0
        # Independent starts: the positions of conf.gro, velocities drawn by each engine at 300 K.
        work.mkdir(parents=True, exist_ok=True)
        lines = (src / "conf.gro").read_text().splitlines()
        start = work / "positions.gro"
        start.write_text("\n".join(lines[:2] + [line[:44] for line in lines[2:-1]] + lines[-1:]) + "\n")
        print(f"{args.seeds} starts from conf.gro's positions with velocities drawn at 300 K (seed = 1..{args.seeds}); "
              "drift kJ/mol/ps/atom, RMS fluctuation kJ/mol, constraint deviation: largest RMS of |r - d|/d, mean T")
        results = {"vimd rattle": [], gmx_name: []}
        for seed in range(1, args.seeds + 1):
            v, g = run_both(work / f"seed{seed}", src, start, setup, args, atoms, seed=seed)
            results["vimd rattle"].append(v)
            results[gmx_name].append(g)
            print(f"  seed {seed}: " + ", ".join(f"{name} {r['drift']:+.3e} (RMS {r['fluct']:.3e}, constraints "
                                                   f"{r['constraint_rms']:.1e}, T {r['temperature']:.1f} K)"
                                                   for name, r in (("vimd rattle", v), (gmx_name, g))),
                  flush=True)
        means = {}
        for name, rs in results.items():
            for key in ("drift", "fluct"):
                d = np.array([r[key] for r in rs])
                means[name, key] = d.mean(), d.std(ddof=1) / np.sqrt(len(d))
            print(f"{name:<16} drift {means[name, 'drift'][0]:+.3e} +- {means[name, 'drift'][1]:.1e}, "
                  f"RMS fluctuation {means[name, 'fluct'][0]:.4e} +- {means[name, 'fluct'][1]:.1e} (mean +- standard error)")
        # The difference of the means in units of its standard error: |z| < 2 is agreement at ~95 %.
        z = []
        for key in ("drift", "fluct"):
            (a, sa), (b, sb) = means["vimd rattle", key], means[gmx_name, key]
            z.append((a - b) / np.hypot(sa, sb))
            print(f"{key}: vimd - {gmx_name} = {a - b:+.3e}, z = {z[-1]:+.2f}")
        if record:
            per_seed = "; ".join(f"{name} drift per seed " + ", ".join(sci(r["drift"], 1, sign=True) for r in rs)
                                 for name, rs in results.items())
            save_results(args, record, gmx_name, args.seeds,
                         *((means[name, "drift"], means[name, "fluct"], rs[0]["simd"]) for name, rs in results.items()),
                         z=z, notes=per_seed)
    return 0


def run_both(work, src, structure, setup, args, atoms, seed):
    """Both engines from `structure` (its velocities, or drawn at 300 K with `seed`): drift,
    fluctuation and block drifts of each."""
    steps = int(round(args.ps / args.dt))
    work.mkdir(parents=True, exist_ok=True)
    velocities = dict(gen_vel="no") if seed is None else dict(gen_vel="yes", gen_temp=300, gen_seed=seed)
    write_mdp(work / "nve.mdp", dt=args.dt, nsteps=steps, nstcalcenergy=10, nstenergy=10,
              nstlog=1000, comm_mode="None", tcoupl="no", pcoupl="no", continuation="no",
              **velocities, **setup["gmx"])
    run([args.gmx, "grompp", "-f", "nve.mdp", "-c", structure, "-p", src / "topol.top", "-o", "nve.tpr", "-maxwarn", "2"], work)
    run([args.gmx, "mdrun", "-s", "nve.tpr", "-deffnm", "gmx_nve", "-nt", str(args.threads), "-pin", "off", "-notunepme"], work)
    e = gmx_energy(args.gmx, "gmx_nve.edr", ["Total-Energy", "Temperature", "Constr.-rmsd"], work)
    gmx = analyse(e["time"], e["Total Energy"], atoms)
    gmx.update(constraint_rms=max(e.get("Constr. rmsd", [0.0])), temperature=np.mean(e["Temperature"]),
               simd=gmx_simd((work / "gmx_nve.log").read_text()))

    integrator = dict(type="rattle", dt=args.dt, steps=steps, constraint_tolerance=setup["tolerance"])
    if seed is not None:
        integrator.update(temperature=300.0, seed=seed)
    vimd_config(work / "nve.toml", structure, src / "topol.top", setup["ff"], integrator,
                dict(dir=str(work / "vimd"), trajectory_every=0, energy_every=10), system=setup.get("system"))
    vimd("run", work / "nve.toml", threads=args.threads)
    summary = json.loads((work / "vimd" / "summary.json").read_text())
    legends, cols = read_xvg(work / "vimd" / "energy.xvg")
    ours = analyse(cols[0], cols[1 + legends.index("total")], atoms)
    ours.update(summary_drift=summary["drift_per_atom"], summary_rms=summary["rms_fluctuation"],
                constraint_rms=max(cols[1 + legends.index("constraint_rms")]),
                temperature=np.mean(cols[1 + legends.index("temperature")]), simd=summary.get("simd_target", "unknown"))
    return ours, gmx


def analyse(t, e, atoms):
    drift, fluct = statistics(t, e, atoms)
    return dict(drift=drift, fluct=fluct, blocks=block_drifts(t, e, atoms))


if __name__ == "__main__":
    sys.exit(main())

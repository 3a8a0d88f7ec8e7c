#!/usr/bin/python3
"""Single-point energies and forces of vimd against `gmx_d mdrun -rerun` on the same structure and topology.

For each water box and each non-bonded setting (reaction field; PME at pme-order 4 and 8), prints
LJ, Coulomb (PME: real space + mesh + corrections, GROMACS's Coulomb (SR) + Coul. recip.), the mesh
part alone, the potential and the RMS force difference relative to the RMS force, and exits
non-zero if any differs by more than 1e-6.
Usage: /usr/bin/python3 validation/gromacs_energy.py [--systems water216 water900 tip3p_solvated]
"""
import argparse
import json
import sys
import tempfile
import pathlib

import MDAnalysis
import numpy as np

from gmx_common import ROOT, run, write_mdp, nonbonded_mdp, gmx_energy, vimd_config, vimd

sys.path.insert(0, str(ROOT / "build" / "python"))
import vimd as vimd_module  # noqa: E402  (the module built next to the vimd program)

PME = dict(ewald_rtol=1e-5, fourier_spacing=0.12)
# label, cut-off, vimd's [forcefield] keys, the systems it runs on
SETTINGS = [
    ("RF eps_rf=0, LJ potential-shift", 0.9,
     dict(vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="reaction-field", epsilon_rf=0),
     ["water216", "water900"]),
    ("RF eps_rf=78, LJ potential-switch 0.7-0.9", 0.9,
     dict(vdw_modifier="potential-switch", vdw_switch=0.7, coulomb="reaction-field", epsilon_rf=78),
     ["water216", "water900"]),
    ("PME order 4 (rtol 1e-5, spacing 0.12), rc 1.0", 1.0,
     dict(vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="pme", pme_order=4, **PME),
     ["water900", "tip3p_solvated"]),
    ("PME order 8 (rtol 1e-5, spacing 0.12), rc 1.0", 1.0,
     dict(vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="pme", pme_order=8, **PME),
     ["water900", "tip3p_solvated"]),
]
# vimd refuses a box shorter than 2 (cut-off + skin), as grompp does with rlist; water216's 1.864 nm
# box allows a skin of at most 0.032 nm (its run.toml uses 0.03). A single point needs no more.
SKIN = 0.03
TOLERANCE = 1e-6


def compare(system, label, cutoff, ff, work):
    src = ROOT / "inputs" / system
    work.mkdir(parents=True, exist_ok=True)
    pme = {k: ff[k] for k in ("ewald_rtol", "pme_order", "fourier_spacing") if k in ff}
    write_mdp(work / "rerun.mdp", integrator="md", nsteps=0, nstfout=1,
              **nonbonded_mdp(cutoff, ff["vdw_modifier"], ff["vdw_switch"], ff.get("epsilon_rf", 0),
                              coulomb=ff["coulomb"], pme=pme))
    run(["gmx_d", "grompp", "-f", "rerun.mdp", "-c", src / "conf.gro", "-p", src / "topol.top", "-o", "rerun.tpr", "-maxwarn", "2"], work)
    run(["gmx_d", "mdrun", "-rerun", src / "conf.gro", "-s", "rerun.tpr", "-nt", "1", "-notunepme",
         "-e", "rerun.edr", "-g", "rerun.log", "-o", "rerun.trr"], work)
    terms = ["LJ-(SR)", "Coulomb-(SR)", "Potential"] + (["Coul.-recip."] if ff["coulomb"] == "pme" else [])
    g = {k: v[0] for k, v in gmx_energy("gmx_d", "rerun.edr", terms, work).items()}
    gmx_forces = MDAnalysis.Universe(str(src / "conf.gro"), str(work / "rerun.trr"), convert_units=False).trajectory[0].forces
    vimd_config(work / "run.toml", src / "conf.gro", src / "topol.top", dict(cutoff=cutoff, neighbor_skin=SKIN, **ff))
    v = json.loads(vimd("energy", work / "run.toml", "--json"))
    # (the module wants velocities for a run; the forces do not depend on them)
    vimd_forces = np.array(vimd_module.Simulation(str(work / "run.toml"), temperature=300.0).forces())
    gmx_coulomb = g["Coulomb (SR)"] + g.get("Coul. recip.", 0.0)
    rows = [("LJ", g["LJ (SR)"], v["lj"]), ("Coulomb", gmx_coulomb, v["coulomb"]), ("Potential", g["Potential"], v["potential"])]
    if ff["coulomb"] == "pme":
        rows.append(("Coul. recip.", g["Coul. recip."], v["coulomb_recip"]))
    out = [(system, label, name, ref, got, abs(got - ref) / abs(ref)) for name, ref, got in rows]
    rms = np.sqrt(np.mean(np.sum((vimd_forces - gmx_forces) ** 2, axis=1)))
    rms_ref = np.sqrt(np.mean(np.sum(gmx_forces.astype(float) ** 2, axis=1)))
    out.append((system, label, "forces RMS", rms_ref, rms, rms / rms_ref))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--systems", nargs="+", default=["water216", "water900", "tip3p_solvated"])
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, (label, cutoff, ff, systems) in enumerate(SETTINGS):
            for system in systems:
                if system in args.systems:
                    rows += compare(system, label, cutoff, ff, pathlib.Path(tmp) / f"{system}_{k}")
    print(f"{'system':<15} {'setting':<46} {'term':<12} {'gmx_d rerun':>20} {'vimd':>20} {'rel. diff':>10}")
    worst = 0.0
    for system, label, name, ref, got, rel in rows:
        print(f"{system:<15} {label:<46} {name:<12} {ref:>20.8f} {got:>20.8f} {rel:>10.1e}")
        worst = max(worst, rel)
    print("forces RMS: the RMS force of gmx_d, then the RMS of the difference")
    print(f"largest relative difference {worst:.2e} (tolerance {TOLERANCE:g})")
    return 0 if worst < TOLERANCE else 1


if __name__ == "__main__":
    sys.exit(main())

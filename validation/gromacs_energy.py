#!/usr/bin/python3
"""Single-point energies of vimd against `gmx_d mdrun -rerun` on the same structure and topology.

For each water box (SPC/E, TIP3P, and TIP4P/2005 with its virtual M site: GROMACS's .trr has zero force on
the site, spread onto O and H as vimd spreads it) and each non-bonded setting (reaction field; PME at
pme-order 4 and 8), prints
LJ, Coulomb (PME: real space + mesh + corrections, GROMACS's Coulomb (SR) + Coul. recip.), the mesh
part alone, the potential, and the RMS force difference over the RMS force. For each molecule box of validation/molecules/ (OPLS-AA
hexanes; a molecule with every dihedral function and parameter lookup; dihedrals whose torsion is
undefined; an AMBER99SB-ILDN decapeptide; a molecule with a virtual site of every kind) and for the
OPLS-AA n-decane melt of inputs/alkane it compares every energy term and the forces (RMS of the
force difference over the RMS force), with reaction field or, for a case ending in "@pme", PME; with
constraints (GROMACS's option, "hexane8:h-bonds") the number of bonds made constraints. Exits
non-zero if any differs by more than 1e-6.
GROMACS runs with a pair list 0.1 nm longer than the cut-off where the box allows (with rlist = rc
its search can miss a pair at the cut-off, and a short buffer still changes forces by ~2e-7) and, for PME, with analytical Ewald kernels (GMX_NBNXN_EWALD_ANALYTICAL: its
default tables carry a force error of ~6e-7 of the RMS force).
`--results FILE` also writes, per case, the largest relative energy difference and the force
difference to a results file (replaced), for validation/tables.py; without it nothing is written.
Usage: /usr/bin/python3 validation/gromacs_energy.py [--systems water216 water900 tip3p_solvated tip4p2005]
                                                    [--molecules hexane8 hexane8:h-bonds alkane@pme ...]
                                                    [--results validation/results/NAME.json]
"""
import argparse
import json
import os
import re
import sys
import tempfile
import pathlib

from gmx_common import (ROOT, gmx_energy, gmx_simd, nonbonded_mdp, results_start, run, sci, vimd, vimd_config,
                        write_mdp, write_results)

import MDAnalysis  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(ROOT / "build" / "python"))
import vimd as vimd_module  # noqa: E402  (the module built next to the vimd program)

# GROMACS's analytical Ewald kernels: its default tables' force error (~6e-7) would hide ours.
os.environ["GMX_NBNXN_EWALD_ANALYTICAL"] = "1"

PME = dict(ewald_rtol=1e-5, fourier_spacing=0.12)
# label, cut-off, vimd's [forcefield] keys, the systems it runs on
SETTINGS = [
    ("RF eps_rf=0, LJ potential-shift", 0.9,
     dict(vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="reaction-field", epsilon_rf=0),
     ["water216", "water900", "tip4p2005"]),
    ("RF eps_rf=78, LJ potential-switch 0.7-0.9", 0.9,
     dict(vdw_modifier="potential-switch", vdw_switch=0.7, coulomb="reaction-field", epsilon_rf=78),
     ["water216", "water900"]),
    ("PME order 4 (rtol 1e-5, spacing 0.12), rc 1.0", 1.0,
     dict(vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="pme", pme_order=4, **PME),
     ["water900", "tip3p_solvated", "tip4p2005"]),
    ("PME order 8 (rtol 1e-5, spacing 0.12), rc 1.0", 1.0,
     dict(vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="pme", pme_order=8, **PME),
     ["water900", "tip3p_solvated"]),
]
CUTOFF = 0.9  # the molecule boxes'
# vimd refuses a box shorter than 2 (cut-off + skin), as grompp does with rlist; water216's 1.864 nm
# box allows a skin of at most 0.032 nm (its run.toml uses 0.03). A single point needs no more.
SKIN = 0.03
TOLERANCE = 1e-6
# The results file's columns: one row per system and setting.
COLUMNS = ["case", "energies, largest relative difference", "forces, RMS difference / RMS force"]


def pair_list_radius(structure, cutoff):
    """GROMACS's rlist: 0.1 nm beyond the cut-off, or as far as half the box allows (grompp's limit)."""
    box = min(float(x) for x in structure.read_text().splitlines()[-1].split()[:3])
    return min(cutoff + 0.1, 0.5 * box - 1e-3)


def sites_placed(src, work):
    """src/conf.gro with its virtual sites placed from their atoms (as vimd places them), as a .g96
    file (9 decimals). GROMACS 2022 places sites in a rerun only with -rerunvsite and without domain
    decomposition, which it uses for PME even on one rank: a reaction-field rerun places them; its
    .trr has the atoms put into the box one by one, so trjconv makes the molecules whole again."""
    write_mdp(work / "place.mdp", integrator="md", nsteps=0, nstxout=1, **nonbonded_mdp(0.9, "potential-shift", 0.0, 0))
    run(["gmx_d", "grompp", "-f", "place.mdp", "-c", src / "conf.gro", "-p", src / "topol.top", "-o", "place.tpr",
         "-maxwarn", "2"], work)
    run(["gmx_d", "mdrun", "-rerun", src / "conf.gro", "-s", "place.tpr", "-nt", "1", "-rerunvsite", "-e", "place.edr",
         "-g", "place.log", "-o", "placed.trr"], work)
    run(["gmx_d", "trjconv", "-f", "placed.trr", "-s", "place.tpr", "-pbc", "mol", "-o", "placed.g96"], work, stdin="0\n")
    return work / "placed.g96"


def compare(system, label, cutoff, ff, work):
    src = ROOT / "inputs" / system
    work.mkdir(parents=True, exist_ok=True)
    has_sites = "virtual_sites" in (src / "topol.top").read_text()
    frame = sites_placed(src, work) if has_sites else src / "conf.gro"
    pme = {k: ff[k] for k in ("ewald_rtol", "pme_order", "fourier_spacing") if k in ff}
    write_mdp(work / "rerun.mdp", integrator="md", nsteps=0, nstfout=1,
              **nonbonded_mdp(cutoff, ff["vdw_modifier"], ff["vdw_switch"], ff.get("epsilon_rf", 0),
                              coulomb=ff["coulomb"], rlist=pair_list_radius(src / "conf.gro", cutoff), pme=pme))
    run(["gmx_d", "grompp", "-f", "rerun.mdp", "-c", src / "conf.gro", "-p", src / "topol.top", "-o", "rerun.tpr", "-maxwarn", "2"], work)
    run(["gmx_d", "mdrun", "-rerun", frame, "-s", "rerun.tpr", "-nt", "1", "-notunepme",
         "-e", "rerun.edr", "-g", "rerun.log", "-o", "rerun.trr"], work)
    terms = ["LJ-(SR)", "Coulomb-(SR)", "Potential"] + (["Coul.-recip."] if ff["coulomb"] == "pme" else [])
    g = {k: v[0] for k, v in gmx_energy("gmx_d", "rerun.edr", terms, work).items()}
    gmx_forces = MDAnalysis.Universe(str(src / "conf.gro"), str(work / "rerun.trr"),
                                     convert_units=False).trajectory[0].forces.astype(float)
    vimd_config(work / "run.toml", src / "conf.gro", src / "topol.top", dict(cutoff=cutoff, neighbor_skin=SKIN, **ff),
                integrator=dict(temperature=300.0))  # a Simulation wants velocities; the forces do not
    v = json.loads(vimd("energy", work / "run.toml", "--json"))
    vimd_forces = np.array(vimd_module.Simulation(str(work / "run.toml")).forces())
    gmx_coulomb = g["Coulomb (SR)"] + g.get("Coul. recip.", 0.0)
    rows = [("LJ", g["LJ (SR)"], v["lj"]), ("Coulomb", gmx_coulomb, v["coulomb"]), ("Potential", g["Potential"], v["potential"])]
    if ff["coulomb"] == "pme":
        rows.append(("Coul. recip.", g["Coul. recip."], v["coulomb_recip"]))
    out = [(system, label, name, ref, got, abs(got - ref) / abs(ref)) for name, ref, got in rows]
    rms_ref = np.sqrt(np.mean(np.sum(gmx_forces ** 2, axis=1)))
    rms = np.sqrt(np.mean(np.sum((vimd_forces - gmx_forces) ** 2, axis=1)))
    out.append((system, label, "forces", rms_ref, float(np.sqrt(np.mean(np.sum(vimd_forces ** 2, axis=1)))), rms / rms_ref))
    return out


# vimd's energy terms as sums of GROMACS's: "dihedrals" holds the proper kinds, "impropers" both
# improper kinds. Terms a system lacks are absent from the .edr (and count as 0).
MOLECULE_TERMS = [
    ("bonds", ["Bond"]),
    ("angles", ["Angle"]),
    ("dihedrals", ["Proper Dih.", "Ryckaert-Bell.", "Fourier Dih."]),
    ("impropers", ["Improper Dih.", "Per. Imp. Dih."]),
    ("lj14", ["LJ-14"]),
    ("coulomb14", ["Coulomb-14"]),
    ("lj", ["LJ (SR)"]),
    ("coulomb", ["Coulomb (SR)", "Coul. recip."]),
    ("potential", ["Potential"]),
]


def tpr_constraint_count(dump):
    """The number of constraints in a `gmx dump -s` of a .tpr: per molecule type (its Constraint
    list holds 3 numbers per constraint) times that type's molecules in each block."""
    per_type, blocks, moltype, block_type, previous = {}, [], None, None, ""
    for line in dump.splitlines():
        words = line.split()
        if line.startswith("   moltype (") and line.rstrip().endswith("):"):
            moltype = int(line.split("(")[1].split(")")[0])
        elif words[:1] == ["moltype"] and "=" in words:
            block_type = int(words[2])
        elif words[:1] == ["#molecules"]:
            blocks.append((block_type, int(words[2])))
        elif words[:1] == ["nr:"] and previous.strip() == "Constraint:":
            per_type[moltype] = int(words[1]) // 3
        previous = line
    return sum(per_type.get(t, 0) * n for t, n in blocks)


def compare_molecules(system, constraints, coulomb, work):
    """Every energy term and the forces of a molecule box (validation/molecules, or inputs), reaction
    field with eps_rf = infinity at the 0.9 nm cut-off or PME as the water boxes run it.
    With constraints (GROMACS's option) the energies at the given positions and the number of
    constraints grompp made; not the forces: vimd's Simulation constrains its start first."""
    src = ROOT / "validation" / "molecules" / system
    if not src.is_dir():
        src = ROOT / "inputs" / system
    work.mkdir(parents=True, exist_ok=True)
    if coulomb == "pme":
        label, cutoff, ff = next((label, cutoff, ff) for label, cutoff, ff, _ in SETTINGS if ff["coulomb"] == "pme")
    else:
        label, cutoff, ff = "RF eps_rf=0", CUTOFF, dict(vdw_modifier="potential-shift", vdw_switch=0.0,
                                                         coulomb="reaction-field", epsilon_rf=0)
    pme = {k: ff[k] for k in ("ewald_rtol", "pme_order", "fourier_spacing") if k in ff}
    write_mdp(work / "rerun.mdp", integrator="md", nsteps=0, nstfout=1, constraints=constraints,
              **nonbonded_mdp(cutoff, ff["vdw_modifier"], ff["vdw_switch"], ff.get("epsilon_rf", 0), coulomb=ff["coulomb"],
                              rlist=pair_list_radius(src / "conf.gro", cutoff), pme=pme))
    run(["gmx_d", "grompp", "-f", "rerun.mdp", "-c", src / "conf.gro", "-p", src / "topol.top", "-o", "rerun.tpr", "-maxwarn", "2"], work)
    # -rerunvsite: virtual sites placed from their atoms, as vimd places them; a PME rerun refuses it
    # (GROMACS 2022 decomposes the domain for PME even on one rank), and no PME case has sites
    placement = ["-rerunvsite"] if coulomb != "pme" else []
    run(["gmx_d", "mdrun", "-rerun", src / "conf.gro", "-s", "rerun.tpr", "-nt", "1", "-notunepme", *placement,
         "-e", "rerun.edr",
         "-g", "rerun.log", "-o", "rerun.trr"], work)
    names = sorted({g for _, gs in MOLECULE_TERMS for g in gs})
    g = gmx_energy("gmx_d", "rerun.edr", [n.replace(" ", "-") for n in names], work)
    vimd_config(work / "run.toml", src / "conf.gro", src / "topol.top", dict(cutoff=cutoff, neighbor_skin=0.1, **ff),
                integrator=dict(temperature=300.0),  # a Simulation wants velocities; the forces do not
                system=dict(constraints=constraints))
    v = json.loads(vimd("energy", work / "run.toml", "--json"))
    label += ", all terms" + (f", constraints {constraints}" if constraints != "none" else "")
    rows = []
    for vkey, gkeys in MOLECULE_TERMS:
        ref, got = sum(g[k][0] for k in gkeys if k in g), v[vkey]
        rows.append((system, label, vkey, ref, got, abs(got - ref) / max(abs(ref), 1e-300)))
    if coulomb == "pme":
        ref, got = g["Coul. recip."][0], v["coulomb_recip"]
        rows.append((system, label, "Coul. recip.", ref, got, abs(got - ref) / abs(ref)))
    if constraints != "none":
        made = tpr_constraint_count(run(["gmx_d", "dump", "-s", "rerun.tpr"], work))
        check = vimd("check", work / "run.toml")
        rigid = int(check.split(" of them bonds made rigid")[0].split()[-1])
        rows.append((system, label, "constraints", made, rigid, abs(rigid - made) / max(made, 1)))
        return rows
    # MDAnalysis gives forces in kJ/mol/Å.
    reference = MDAnalysis.Universe(str(work / "rerun.tpr"), str(work / "rerun.trr")).trajectory[0].forces * 10.0
    forces = np.array(vimd_module.Simulation(str(work / "run.toml")).forces())  # kJ/mol/nm
    # Relative to the RMS force; absolute where GROMACS's forces are all zero (collinear).
    rms = np.sqrt(np.mean(np.sum((forces - reference) ** 2, axis=1)) / max(np.mean(np.sum(reference ** 2, axis=1)), 1.0))
    rows.append((system, label, "forces", float(np.sqrt(np.mean(np.sum(reference ** 2, axis=1)))),
                 float(np.sqrt(np.mean(np.sum(forces ** 2, axis=1)))), float(rms)))
    return rows


def results_rows(rows):
    """Per system and setting, the largest relative difference of its energy terms and that of its forces
    (the constraint count is checked by the exit status, not tabled)."""
    energies, forces = {}, {}
    for system, label, name, _, _, rel in rows:
        case = f"{system}: {label}"
        if name == "forces":
            forces[case] = rel
        elif name != "constraints":
            energies[case] = max(rel, energies.get(case, 0.0))
    return [{COLUMNS[0]: case, COLUMNS[1]: sci(worst)} | ({COLUMNS[2]: sci(forces[case])} if case in forces else {})
            for case, worst in energies.items()]


def platform(work):
    """The SIMD targets of a run's programs: vimd's from `vimd check`, gmx_d's from its rerun's log."""
    target = re.search(r"^platform\s+SIMD (\S+)", vimd("check", next(work.rglob("run.toml"))), re.MULTILINE)
    gmx_log = next(work.rglob("rerun.log")).read_text()
    return f"vimd {target.group(1) if target else 'unknown'}; gmx_d {gmx_simd(gmx_log)}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--systems", nargs="*", default=["water216", "water900", "tip3p_solvated", "tip4p2005"])
    ap.add_argument("--molecules", nargs="*",
                    default=["hexane8", "hexane8:h-bonds", "torsions", "torsions:all-bonds", "collinear",
                             "peptide_amber", "peptide_amber:h-bonds", "vsites", "alkane", "alkane@pme"],
                    help="molecule boxes of validation/molecules or inputs, each optionally with :constraints "
                         "and @pme")
    ap.add_argument("--results", type=pathlib.Path, help="also write the differences to this results file (replaced)")
    args = ap.parse_args()
    record = results_start("agreement") if args.results else None
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for system in args.systems:
            for k, (label, cutoff, ff, systems) in enumerate(SETTINGS):
                if system in systems:
                    rows += compare(system, label, cutoff, ff, pathlib.Path(tmp) / f"{system}_{k}")
        for case in args.molecules:
            case_name, _, coulomb = case.partition("@")
            system, _, constraints = case_name.partition(":")
            rows += compare_molecules(system, constraints or "none", coulomb or "reaction-field",
                                      pathlib.Path(tmp) / case.replace(":", "_").replace("@", "_"))
        if record and rows:
            record.update(simd=platform(pathlib.Path(tmp)), columns=COLUMNS, rows=results_rows(rows),
                          notes="gmx_d with GMX_NBNXN_EWALD_ANALYTICAL=1")
            write_results(args.results, record)
    print(f"{'system':<14} {'setting':<52} {'term':<10} {'gmx_d rerun':>20} {'vimd':>20} {'rel. diff':>10}")
    print("(forces: the RMS force of each, and the RMS of the difference over the RMS force)")
    worst = 0.0
    for system, label, name, ref, got, rel in rows:
        print(f"{system:<14} {label:<52} {name:<10} {ref:>20.8f} {got:>20.8f} {rel:>10.1e}")
        worst = max(worst, rel)
    print(f"largest relative difference {worst:.2e} (tolerance {TOLERANCE:g})")
    return 0 if worst < TOLERANCE else 1


if __name__ == "__main__":
    sys.exit(main())

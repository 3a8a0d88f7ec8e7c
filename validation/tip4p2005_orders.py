#!/usr/bin/python3
"""Global orders of RATTLE, vi rk4, vi rk6 and vi rk8 on rigid TIP4P/2005 water with its virtual M site.

A cluster of 8 molecules cut from inputs/tip4p2005 (the molecule nearest the box centre and its 7
nearest neighbours, made whole) in a 6 nm box, every pair inside the 1.5 nm cut-off with LJ and the
reaction field potential-switched (C4) from 1.2 nm, so the forces are smooth along the trajectory.
Prints, per integrator, the RMS error of the real atoms' positions at 0.2 ps against vi rk8 at
0.0625 fs, and the slopes of log(error) over log(dt).
Usage: /usr/bin/python3 validation/tip4p2005_orders.py   (needs build/python; a few seconds)
"""
import pathlib
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "build" / "python"))
import vimd  # noqa: E402

END_TIME = 0.2  # ps
RUN_TOML = """[system]
structure = "conf.gro"
topology = "topol.top"
[forcefield]
cutoff = 1.5
vdw_modifier = "potential-switch"
vdw_switch = 1.2
coulomb = "reaction-field"
epsilon_rf = 0.0
coulomb_modifier = "potential-switch"
coulomb_switch = 1.2
switch_smoothness = 4
neighbor_skin = 0.1
[integrator]
constraint_tolerance = 1e-13
[output]
trajectory_every = 0
energy_every = 0
"""


def write_cluster(directory, molecules=8, box_edge=6.0):
    """The cluster's conf.gro (8 decimals), topol.top and run.toml."""
    lines = (ROOT / "inputs" / "tip4p2005" / "conf.gro").read_text().splitlines()
    n = int(lines[1])
    box = np.array([float(x) for x in lines[-1].split()[:3]])
    atoms = lines[2:2 + n]
    x = np.array([[float(line[20 + 8 * k:28 + 8 * k]) for k in range(3)] for line in atoms])
    v = np.array([[float(line[44 + 8 * k:52 + 8 * k]) for k in range(3)] for line in atoms])
    oxygens = x[0::4]
    to_centre = oxygens - box / 2
    to_centre -= box * np.round(to_centre / box)
    first = int(np.argmin((to_centre ** 2).sum(1)))
    offsets = oxygens - oxygens[first]
    offsets -= box * np.round(offsets / box)  # minimum image: the cluster whole around `first`
    out = ["TIP4P/2005 cluster from inputs/tip4p2005", str(4 * molecules)]
    for new, m in enumerate(np.argsort((offsets ** 2).sum(1))[:molecules]):
        for a in range(4):
            i = 4 * m + a
            p = x[i] + offsets[m] - (oxygens[m] - oxygens[first]) - oxygens[first] + box_edge / 2
            out.append(f"{new + 1:5d}SOL  {atoms[i][10:15]}{4 * new + a + 1:5d}" + "".join(f"{c:13.8f}" for c in p) +
                       "".join(f"{c:13.8f}" for c in v[i]))
    out.append(f"{box_edge:10.5f}{box_edge:10.5f}{box_edge:10.5f}")
    (directory / "conf.gro").write_text("\n".join(out) + "\n")
    top = (ROOT / "inputs" / "tip4p2005" / "topol.top").read_text()
    (directory / "topol.top").write_text(top.replace(f"SOL {n // 4}", f"SOL {molecules}"))
    (directory / "run.toml").write_text(RUN_TOML)


def main():
    with tempfile.TemporaryDirectory() as tmp:
        directory = pathlib.Path(tmp)
        write_cluster(directory)
        config = str(directory / "run.toml")
        n_atoms = vimd.Simulation(config).n_atoms
        real = np.arange(n_atoms) % 4 != 3  # the M sites follow their atoms

        def final(integrator, dt, **settings):
            steps = int(round(END_TIME / dt))
            if abs(steps * dt - END_TIME) > 1e-9 * END_TIME:
                raise ValueError(f"dt = {dt} ps does not divide the {END_TIME} ps the errors are compared at")
            s = vimd.Simulation(config, integrator=integrator, dt=dt, **settings)
            s.step(steps)
            return np.array(s.positions)[real]

        reference = final("vi", 0.0000625, method="rk8", solver_tolerance=1e-14)
        for label, integrator, settings, dts in [
                ("rattle", "rattle", {}, [0.002, 0.001, 0.0005, 0.00025]),
                ("vi rk4", "vi", dict(method="rk4", solver_tolerance=1e-14), [0.004, 0.002, 0.001, 0.0005]),
                ("vi rk6", "vi", dict(method="rk6", solver_tolerance=1e-14), [0.004, 0.002, 0.001, 0.0005]),
                ("vi rk8", "vi", dict(method="rk8", solver_tolerance=1e-14), [0.004, 0.0025, 0.002, 0.00125])]:
            errors = [np.sqrt(((final(integrator, dt, **settings) - reference) ** 2).sum(1).mean()) for dt in dts]
            local = [np.log(errors[k] / errors[k + 1]) / np.log(dts[k] / dts[k + 1]) for k in range(len(dts) - 1)]
            fitted = np.polyfit(np.log(dts), np.log(errors), 1)[0]
            print(f"{label:7s} dt/fs " + " ".join(f"{1000 * d:g}" for d in dts) + "   RMS error/nm " +
                  " ".join(f"{e:.2e}" for e in errors) + "   local slopes " + " ".join(f"{s:.2f}" for s in local) +
                  f"   fitted {fitted:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

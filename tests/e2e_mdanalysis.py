#!/usr/bin/python3
"""End-to-end: run vimd (RATTLE) on the 216-water box, then open its outputs with MDAnalysis
exactly as a user would, Universe(confout.gro, traj.trr), and check what is in them.
Usage: e2e_mdanalysis.py VIMD_BINARY SOURCE_DIR WORK_DIR"""
import json
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import MDAnalysis as mda

vimd, src, work = sys.argv[1], pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])
shutil.rmtree(work, ignore_errors=True)
work.mkdir(parents=True)
config = work / "run.toml"
text = (src / "inputs/water216/run.toml").read_text()
text = text.replace('"conf.gro"', f'"{src}/inputs/water216/conf.gro"').replace('"topol.top"', f'"{src}/inputs/water216/topol.top"')
text = text.replace("trajectory_every = 100", "trajectory_every = 5")
config.write_text(text)
subprocess.run([vimd, "run", str(config), "--steps", "20", "--out", str(work / "out")], check=True)

out = work / "out"
u = mda.Universe(str(out / "confout.gro"), str(out / "traj.trr"))
assert len(u.atoms) == 648, len(u.atoms)
assert u.trajectory.n_frames == 5, u.trajectory.n_frames  # steps 0, 5, 10, 15, 20
ts = u.trajectory[-1]
assert ts.has_velocities and ts.has_forces, "trr frames must carry v and f"
assert abs(ts.time - 0.040) < 1e-9, ts.time
np.testing.assert_allclose(ts.dimensions[:3], u.dimensions[:3], rtol=1e-6)
final = mda.Universe(str(out / "confout.gro"))
# confout.gro has 3 decimals; the trajectory's last frame is the same state in double precision (Å in MDAnalysis).
np.testing.assert_allclose(ts.positions, final.atoms.positions, atol=0.0051)
# Rigid water: O-H distances in the last frame at 1 Å (MDAnalysis holds float32: ~1e-6 Å resolution at 10 Å).
oh = np.linalg.norm(u.atoms.positions[1::3] - u.atoms.positions[0::3], axis=1)
assert np.max(np.abs(oh - 1.0)) < 1e-5, np.max(np.abs(oh - 1.0))
summary = json.loads((out / "summary.json").read_text())
assert summary["steps"] == 20 and summary["atoms"] == 648
print(f"MDAnalysis read {u.trajectory.n_frames} frames of {len(u.atoms)} atoms; max |O-H - 0.1 nm| = {np.max(np.abs(oh - 1.0)) / 10:.1e} nm")

# GROMACS's own reader accepts the trajectory too: double precision, every frame with x, v, f and box.
check = subprocess.run(["gmx", "check", "-f", str(out / "traj.trr")], capture_output=True, text=True)
assert check.returncode == 0, check.stdout + check.stderr
text = check.stdout + check.stderr
assert "(double precision)" in text, text[-2000:]
counts = {row.split()[0]: int(row.split()[1]) for row in text.splitlines()
          if row.split()[:1] and row.split()[0] in ("Coords", "Velocities", "Forces", "Box")}
assert counts == {"Coords": 5, "Velocities": 5, "Forces": 5, "Box": 5}, counts
print(f"gmx check read the same {counts['Coords']} frames (double precision, x, v, f, box)")

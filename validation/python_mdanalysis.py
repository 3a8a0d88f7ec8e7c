#!/usr/bin/python3
"""Hands a trajectory kept in memory by vimd's Python module to MDAnalysis (MemoryReader): 200
RATTLE steps of water216, frames every 10 steps, then the O-O radial distribution function's first
peak and the mean O-H bond length (rigid: 0.1 nm). Set-up: see docs/user-guide.md (PYTHONPATH=build/python)."""
import pathlib
import numpy as np
import MDAnalysis as mda
from MDAnalysis.analysis.rdf import InterRDF
from MDAnalysis.coordinates.memory import MemoryReader
import vimd

run_file = pathlib.Path(__file__).resolve().parent.parent / "inputs" / "water216" / "run.toml"
sim = vimd.Simulation(run_file)
frames = [np.array(sim.positions)]
sim.run(200, callback=lambda s: frames.append(np.array(s.positions)), every=10)
coordinates = 10.0 * np.stack(frames)  # nm -> Angstrom, (frames, atoms, 3)
u = mda.Universe(str(sim.structure), coordinates, format=MemoryReader,
                 dimensions=np.r_[10.0 * sim.box, 90.0, 90.0, 90.0])
print(f"{len(u.trajectory)} frames of {u.atoms.n_atoms} atoms in memory")
oxygens = u.select_atoms("name OW")
rdf = InterRDF(oxygens, oxygens, nbins=75, range=(1.0, 8.0), exclusion_block=(1, 1)).run()
print(f"O-O g(r) first peak {rdf.results.bins[np.argmax(rdf.results.rdf)]:.2f} A (height {rdf.results.rdf.max():.2f})")
oh = [np.linalg.norm(u.atoms.positions[1::3] - u.atoms.positions[0::3], axis=1).mean() for _ in u.trajectory]
print(f"mean O-H distance {np.mean(oh) / 10:.5f} nm over the frames")

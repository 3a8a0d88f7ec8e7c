#!/usr/bin/python3
"""RATTLE and the variational RK4 integrator on water216 from Python: total energy over 1 ps,
plotted with matplotlib (validation/python_rattle_vs_vi.png). Set-up: see docs/user-guide.md (PYTHONPATH=build/python)."""
import pathlib
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import vimd

here = pathlib.Path(__file__).resolve().parent
run_file = here.parent / "inputs" / "water216" / "run.toml"
fig, ax = plt.subplots(figsize=(7, 4))
for label, settings in [("RATTLE", dict(integrator="rattle")), ("vi (RK4)", dict(integrator="vi", method="rk4"))]:
    sim = vimd.Simulation(run_file, **settings)
    sim.step(0)  # the start the engine makes of the .gro: constrained positions and velocities
    t, e = [sim.time], [sim.energy()["potential"] + sim.kinetic_energy()]
    sim.run(500, callback=lambda s: (t.append(s.time), e.append(s.energy()["potential"] + s.kinetic_energy())), every=5)
    s = sim.summary()
    print(f"{label:9} drift {s['drift_per_atom']:+.2e} kJ/mol/ps/atom, RMS {s['rms_fluctuation']:.3f} kJ/mol, "
          f"{s['force_evaluations'] / s['steps']:.2f} force evaluations/step, {s['wall_seconds']:.1f} s")
    ax.plot(t, e, label=label)
ax.set(xlabel="time (ps)", ylabel="total energy (kJ/mol)", title="water216, dt = 2 fs")
ax.legend()
fig.savefig(here / "python_rattle_vs_vi.png", dpi=120, bbox_inches="tight")

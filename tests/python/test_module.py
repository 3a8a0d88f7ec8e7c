"""The Python module against the command line: the same energies and the same trajectory, bit for
bit, and the command line's error messages as Python exceptions.

Run by ctest (tests/scripts.cmake) as
  VIMD_CLI=build/vimd PYTHONPATH=build/python /usr/bin/python3 -m pytest tests/python
"""
import json
import os
import pathlib
import struct
import subprocess
import sys
import threading

import numpy as np
import pytest

import vimd

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLI = os.environ.get("VIMD_CLI", str(ROOT / "build" / "vimd"))
WATER = ROOT / "inputs" / "water216" / "run.toml"
TIP3P = ROOT / "inputs" / "tip3p_solvated" / "run_min.toml"


def cli(*args):
    p = subprocess.run([CLI, *map(str, args)], text=True, capture_output=True)
    return p.returncode, p.stdout, p.stderr


def read_trr_last_frame(path):
    """Step, x, v, f of the last frame of a double-precision .trr (as engine/gromacs/trr.cpp writes it)."""
    data = pathlib.Path(path).read_bytes()
    pos, frame = 0, None
    while pos < len(data):
        ints = lambda n: struct.unpack_from(f">{n}i", data, pos)
        magic, _, length = ints(3)
        assert magic == 1993
        pos += 12 + length + (4 - length % 4) % 4
        sizes = ints(13)
        pos += 52
        box_size, x_size, v_size, f_size, natoms, step = sizes[2], sizes[7], sizes[8], sizes[9], sizes[10], sizes[11]
        assert box_size == 72, "not a double-precision file"
        pos += 16 + box_size
        arrays = []
        for size in (x_size, v_size, f_size):
            arrays.append(np.frombuffer(data, ">f8", natoms * 3, pos).reshape(natoms, 3).astype(float) if size else None)
            pos += size
        frame = (step, *arrays)
    return frame


def write_config(path, source, **integrator):
    """A copy of a run file with absolute input paths and [integrator] settings replaced."""
    text = source.read_text()
    for name in ("conf.gro", "topol.top"):
        text = text.replace(f'"{name}"', json.dumps(str(source.parent / name)))
    lines, table = [], None
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("["):
            table = stripped
        key = stripped.split("=")[0].strip()
        if table == "[integrator]" and key in integrator:
            continue
        lines.append(line)
        if stripped == "[integrator]":
            lines += [f"{k} = {json.dumps(v)}" for k, v in integrator.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("config", [WATER, TIP3P])
def test_energy_equals_cli_json_bit_for_bit(config):
    rc, out, err = cli("energy", config, "--json")
    assert rc == 0, err
    expected = json.loads(out)
    got = vimd.Simulation(config).energy()
    assert list(got) == list(expected)
    for key in expected:
        assert got[key] == expected[key], key  # exact: the same code on the same doubles


def test_molecule_terms_and_bond_constraints(tmp_path):
    """Dihedrals, impropers and 1-4 pairs reach Python as the command line has them, and
    constraints = "h-bonds" is a setting like any other."""
    src = ROOT / "validation" / "molecules" / "torsions"
    config = tmp_path / "run.toml"
    config.write_text(f'[system]\nstructure = "{src / "conf.gro"}"\ntopology = "{src / "topol.top"}"\n'
                      '[integrator]\ntemperature = 300.0\n')
    rc, out, err = cli("energy", config, "--json")
    assert rc == 0, err
    expected = json.loads(out)
    got = vimd.Simulation(config).energy()
    assert list(got) == ["lj", "coulomb", "bonds", "angles", "dihedrals", "impropers", "lj14", "coulomb14",
                         "potential"]
    for key in expected:
        assert got[key] == expected[key], key
    for key in ("dihedrals", "impropers", "lj14", "coulomb14"):
        assert got[key] != 0, key
    rc, out, err = cli("check", config)
    assert "0 of them bonds made rigid" in out
    rigid_config = tmp_path / "rigid.toml"
    rigid_config.write_text(config.read_text().replace("[integrator]", 'constraints = "h-bonds"\n[integrator]'))
    rc, out, err = cli("check", rigid_config)
    assert rc == 0, err
    assert '6 of them bonds made rigid (constraints = "h-bonds")' in out
    rigid = vimd.Simulation(config, constraints="h-bonds")  # the three C-H bonds of each molecule
    assert rigid.energy()["bonds"] != got["bonds"]
    with pytest.raises(vimd.InputError, match='did you mean "h-bonds"'):
        vimd.Simulation(config, constraints="hbonds")


@pytest.mark.parametrize("integrator", [
    dict(type="rattle"),
    dict(type="shake"),
    dict(type="vi", method="rk4"),
    dict(type="rattle", thermostat="v-rescale", temperature=300.0, tau_t=0.1, seed=7),
    dict(type="minimize", emtol=1.0),
])
def test_step_equals_cli_run_bit_for_bit(tmp_path, integrator):
    n = 12
    source = TIP3P if integrator["type"] == "minimize" else WATER
    config = write_config(tmp_path / "run.toml", source, **integrator)
    text = config.read_text().replace("trajectory_every = 0", f"trajectory_every = {n}")
    config.write_text(text.replace("trajectory_every = 100", f"trajectory_every = {n}"))
    rc, out, err = cli("run", config, "--steps", n, "--out", tmp_path / "out")
    assert rc == 0, err
    step, x, v, f = read_trr_last_frame(tmp_path / "out" / "traj.trr")
    assert step == n

    sim = vimd.Simulation(config)
    sim.step(n)
    assert sim.current_step == n
    assert np.array_equal(sim.positions, x)
    assert np.array_equal(sim.velocities, v)
    assert np.array_equal(sim.forces(), f)


@pytest.mark.parametrize("observe", ["energy", "forces"])
@pytest.mark.parametrize("integrator", [dict(type="rattle"), dict(type="vi", method="rk4")])
def test_observing_the_start_does_not_change_the_run(tmp_path, observe, integrator):
    # The start is not on the constraint manifold yet: an observation there must not leave its
    # evaluation (neighbour lists built at those positions) to the run, which starts constrained.
    config = write_config(tmp_path / "run.toml", WATER, **integrator)
    plain = vimd.Simulation(config)
    plain.step(20)
    observed = vimd.Simulation(config)
    getattr(observed, observe)()
    observed.step(20)
    assert np.array_equal(observed.positions, plain.positions)
    assert np.array_equal(observed.velocities, plain.velocities)


def test_chunked_steps_continue_one_run():
    a = vimd.Simulation(WATER)
    a.step(6)
    a.step(4)
    b = vimd.Simulation(WATER)
    b.step(10)
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.velocities, b.velocities)


def test_arrays_are_read_only_views_of_the_state():
    sim = vimd.Simulation(WATER)
    x = sim.positions
    assert x.shape == (sim.n_atoms, 3) and x.dtype == np.float64 and x.flags.c_contiguous
    assert not x.flags.writeable and not x.flags.owndata
    assert np.shares_memory(x, sim.positions)  # no copy per access
    with pytest.raises(ValueError):
        x[0, 0] = 1.0
    assert sim.velocities.shape == (sim.n_atoms, 3)
    assert sim.forces().shape == (sim.n_atoms, 3)


def test_setting_positions_copies_and_restarts():
    sim = vimd.Simulation(WATER)
    shifted = np.array(sim.positions) + 0.01
    sim.positions = shifted
    assert np.array_equal(sim.positions, shifted)
    moved = sim.energy()
    assert moved["potential"] == pytest.approx(vimd.Simulation(WATER).energy()["potential"], rel=1e-10)  # periodic
    sim.step(2)
    assert sim.current_step == 2
    with pytest.raises(vimd.InputError, match=r"positions must have shape \(648, 3\), got \(3, 648\)"):
        sim.positions = np.zeros((3, 648))


def test_run_calls_back_every_n_steps_and_summarises():
    sim = vimd.Simulation(WATER)
    seen = []
    sim.run(10, callback=lambda s: seen.append((s.current_step, s.energy()["potential"])), every=4)
    assert [step for step, _ in seen] == [4, 8, 10]
    summary = sim.summary()
    assert summary["steps"] == 10 and summary["integrator"] == "rattle"
    assert summary["potential"] == sim.energy()["potential"]
    assert abs(summary["temperature"] - sim.temperature()) < 1e-9
    assert summary["samples"] == 2  # steps 0 and 10 (energy_every = 10)


def test_integrator_and_tableau_from_python():
    sim = vimd.Simulation(WATER, integrator="vi", method="rk6", dt=0.001)
    assert sim.integrator.startswith("vi")
    heun = vimd.Tableau([[0, 0], [1, 0]], [0.5, 0.5], order=2)
    assert heun.c == [0.0, 1.0]
    sim = vimd.Simulation(WATER, integrator="vi", tableau=heun, steps=np.int64(2), dt=np.float64(0.001))
    sim.run()
    assert sim.current_step == 2


def cli_error(*args):
    rc, _, err = cli(*args)
    assert rc == 2
    prefix = "vimd: input error: "
    assert err.startswith(prefix), err
    return err[len(prefix):].strip()


def test_errors_carry_the_cli_messages(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(WATER.read_text().replace('"conf.gro"', json.dumps(str(WATER.parent / "conf.gro")))
                   .replace('"topol.top"', json.dumps(str(WATER.parent / "topol.top")))
                   .replace("steps = 5000", "stpes = 5000"))
    message = cli_error("check", bad)
    with pytest.raises(vimd.InputError) as e:
        vimd.Simulation(bad)
    assert str(e.value) == message
    assert isinstance(e.value, ValueError)
    with pytest.raises(vimd.InputError, match="cannot open config file"):
        vimd.Simulation(tmp_path / "missing.toml")


def test_bad_settings_are_input_errors():
    with pytest.raises(vimd.InputError, match=r"unknown setting 'dtt'; did you mean 'dt'\?"):
        vimd.Simulation(WATER, dtt=0.001)
    with pytest.raises(vimd.InputError, match="dt must be positive"):
        vimd.Simulation(WATER, dt=-1.0)
    with pytest.raises(vimd.InputError, match=r'type = "vi" cannot use thermostat = "v-rescale"'):
        vimd.Simulation(WATER, integrator="vi", thermostat="v-rescale", temperature=300.0)
    with pytest.raises(vimd.InputError, match='did you mean "rattle"'):
        vimd.Simulation(WATER, integrator="ratle")
    with pytest.raises(vimd.InputError, match="order"):
        vimd.Tableau([[0, 0], [1, 0]], [0.5, 0.5], order=3)  # Heun is order 2
    with pytest.raises(vimd.InputError, match="unsupported type"):
        vimd.Simulation(WATER, dt=object())


def test_non_convergence_is_a_python_exception():
    sim = vimd.Simulation(WATER, integrator="vi", max_iterations=1, solver_tolerance=1e-14)
    with pytest.raises(vimd.ConvergenceError, match="did not converge at step 1"):
        sim.step(3)


def test_a_failed_step_leaves_the_last_good_state():
    # Not the half-made step's positions under an unchanged step count (a 0.5 ps step tears the
    # water apart: RATTLE fails at step 1, its positions already moved).
    sim = vimd.Simulation(WATER, dt=0.5)
    start = vimd.Simulation(WATER, dt=0.5)
    start.step(0)  # the constrained start, as the failing run begins from it
    with pytest.raises(vimd.ConvergenceError, match="at step 1"):
        sim.step(3)
    assert sim.current_step == 0 and sim.time == 0
    np.testing.assert_array_equal(sim.positions, start.positions)
    assert sim.energy()["potential"] == pytest.approx(start.energy()["potential"], rel=1e-12)


def test_assigning_positions_in_a_callback_is_refused_not_a_crash():
    # In a subprocess: the assignment used to free the running loop under it (exit 139), which
    # would take the test runner down with it.
    script = f"""
import numpy as np, vimd
sim = vimd.Simulation({str(WATER)!r})
try:
    sim.run(5, callback=lambda s: setattr(s, "positions", np.array(s.positions)))
except RuntimeError as e:
    print("refused:", e)
print("step", sim.current_step)
"""
    p = subprocess.run([sys.executable, "-c", script], text=True, capture_output=True)
    assert p.returncode == 0, p.stderr
    assert "refused: vimd.Simulation: cannot assign positions from a run() callback" in p.stdout
    assert "assign positions after run() returns" in p.stdout
    assert p.stdout.endswith("step 1\n")  # the run stopped where the callback raised


def test_step_from_a_callback_is_refused_and_the_run_keeps_its_count():
    sim = vimd.Simulation(WATER)
    refused = []

    def nested(s):
        try:
            s.step(5)
        except RuntimeError as e:
            refused.append(str(e))

    sim.run(10, callback=nested, every=5)
    assert len(refused) == 2 and "cannot call step() from a run() callback" in refused[0]
    assert sim.current_step == 10
    assert sim.time == pytest.approx(10 * 0.002, rel=1e-12)
    with pytest.raises(RuntimeError, match=r"cannot call run\(\) from a run\(\) callback"):
        sim.run(2, callback=lambda s: s.run(1))


def test_reading_in_a_callback_changes_nothing():
    # The callback's energy() and forces() are the integrator's own: computing them afresh would
    # replace the forces the next step uses with ones that differ in the last bits.
    plain = vimd.Simulation(WATER)
    plain.step(10)
    observed = vimd.Simulation(WATER)
    seen = []
    observed.run(10, callback=lambda s: seen.append((s.energy()["potential"], np.array(s.forces()))), every=1)
    assert len(seen) == 10
    assert np.array_equal(observed.positions, plain.positions)
    assert np.array_equal(observed.velocities, plain.velocities)
    assert seen[-1][0] == plain.energy()["potential"]
    assert np.array_equal(seen[-1][1], plain.forces())


def test_another_thread_cannot_use_a_running_simulation():
    sim = vimd.Simulation(WATER)
    inside, release = threading.Event(), threading.Event()
    runner_errors = []

    def hold(s):  # keeps the run in its callback until the main thread has tried
        inside.set()
        release.wait(timeout=120)

    def runner():
        try:
            sim.run(3, callback=hold, every=3)
        except Exception as e:  # noqa: BLE001 - reported by the assertion below
            runner_errors.append(e)

    thread = threading.Thread(target=runner)
    thread.start()
    try:
        assert inside.wait(timeout=120)
        with pytest.raises(RuntimeError, match=r"cannot call step\(\) here: a step\(\) or run\(\) in another thread"):
            sim.step(1)
        with pytest.raises(RuntimeError, match="cannot read positions here"):
            sim.positions
        with pytest.raises(RuntimeError, match="cannot assign velocities here"):
            sim.velocities = np.zeros((sim.n_atoms, 3))
    finally:
        release.set()
        thread.join()
    assert runner_errors == []
    assert sim.current_step == 3 and sim.time == pytest.approx(3 * 0.002, rel=1e-12)
    sim.step(1)  # free again once the run has returned
    assert sim.current_step == 4


def test_non_finite_positions_and_velocities_are_refused_naming_the_atom():
    sim = vimd.Simulation(WATER)
    before = sim.energy()
    x = np.array(sim.positions)
    x[3, 0] = np.nan
    with pytest.raises(vimd.InputError, match=r"positions must be finite: atom 4 \(OW of SOL 2\) has \(nan, "):
        sim.positions = x
    v = np.array(sim.velocities)
    v[7, 2] = -np.inf
    with pytest.raises(vimd.InputError, match=r"velocities must be finite: atom 8 \(HW1 of SOL 3\) has .*-inf\)"):
        sim.velocities = v
    assert sim.energy() == before  # nothing was changed
    assert np.isfinite(sim.positions).all() and np.isfinite(sim.velocities).all()

"""Running vimd and GROMACS for the study. Every run gets a config file in the report directory
(so each table row names a command a reader can rerun) and an output directory in the runs
directory; the result is a plain dict that goes into results.json and the report."""
import hashlib
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import time

import numpy as np

from gmx_common import ROOT, write_mdp, nonbonded_mdp, gmx_energy, gmx_env, vimd_config
from . import energy
from .plan import fs, relative

# How an engine says it does not know an integrator type or method (an input error raised before
# the first step), as opposed to a failure during the run (non-convergence, constraint failure).
REJECTION = re.compile(r"unknown|not (yet )?implemented|not available|unsupported|invalid|expected one of|"
                       r"did you mean|must be one of|not a valid|under construction", re.IGNORECASE)


def _last_words(text, limit=400):
    """The informative end of a failed command's output: the last lines mentioning an error, else
    the last non-empty line."""
    lines = [l.strip() for l in text.splitlines() if l.strip()]
    errors = [l for l in lines if re.search(r"error|fail|converge|unstable|nan", l, re.IGNORECASE)]
    picked = errors[-2:] if errors else lines[-1:]
    return " / ".join(picked)[:limit] or "(no output)"


class Runner:
    def __init__(self, vimd, report_dir, runs_dir, threads, reuse, log=print):
        self.vimd_path = pathlib.Path(vimd).resolve()
        self.config_dir = pathlib.Path(report_dir) / "configs"
        self.runs_dir = pathlib.Path(runs_dir)
        self.threads = threads
        self.reuse = reuse
        self.log = log
        stat = self.vimd_path.stat() if self.vimd_path.exists() else None
        self.binary_id = f"{stat.st_size}:{stat.st_mtime_ns}" if stat else "missing"
        self.run_seconds = 0.0  # wall time of every run the report uses, as measured when it ran

    # ---------------------------------------------------------------- helpers
    def _env(self, threads):
        """vimd gets the thread count through OMP_NUM_THREADS; GROMACS (threads None) through -nt only
        (mdrun refuses an OMP_NUM_THREADS that disagrees with -nt)."""
        env = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"}
        if threads:
            env["OMP_NUM_THREADS"] = str(threads)
            return env
        return gmx_env(env)

    def _cached(self, key_file, key):
        if not (self.reuse and key_file.exists()):
            return None
        stored = json.loads(key_file.read_text())
        return stored if stored.get("key") == key else None

    def _execute(self, args, log_file, timeout, threads=None):
        """Run a command from the repository root with `threads` OpenMP threads (None: the
        environment without OMP_NUM_THREADS); (returncode, combined output, wall seconds)."""
        start = time.monotonic()
        try:
            p = subprocess.run(args, cwd=ROOT, env=self._env(threads), text=True, capture_output=True, timeout=timeout)
            rc, out = p.returncode, p.stdout + p.stderr
        except subprocess.TimeoutExpired as e:
            rc, out = -1, f"{e.stdout or ''}{e.stderr or ''}\nstudy: timeout after {timeout} s"
        wall = time.monotonic() - start
        log_file.write_text(out)
        return rc, out, wall

    # ---------------------------------------------------------------- vimd
    def vimd(self, system, variant, dt, ps, tag, energy_every, trajectory_every, overrides=None,
             tolerance=1e-10, timeout=3600, stability_fraction=0.01, threads=None):
        """One vimd run; `threads` overrides the study's thread count (a section measuring wall time
        at a stated thread count)."""
        threads = threads or self.threads
        steps = int(round(ps / dt))
        name = f"{variant.key}_dt{fs(dt)}fs"
        config = self.config_dir / tag / f"{name}.toml"
        out = self.runs_dir / tag / name
        config.parent.mkdir(parents=True, exist_ok=True)
        out.parent.mkdir(parents=True, exist_ok=True)
        integrator = dict(variant.integrator) | {"dt": dt, "steps": steps, "constraint_tolerance": tolerance}
        integrator |= overrides or {}
        rel = lambda p: os.path.relpath(p, config.parent)
        vimd_config(config, rel(system.structure), rel(system.topology), system.forcefield, integrator,
                    {"dir": rel(out), "trajectory_every": trajectory_every, "energy_every": energy_every},
                    system.system_keys)
        args = [relative(self.vimd_path), "run", relative(config), "--out", relative(out)]
        result = {"kind": "vimd", "system": system.name, "variant": variant.key, "label": variant.label,
                  "dt": dt, "steps": steps, "ps": steps * dt, "atoms": system.atoms,
                  "command": f"OMP_NUM_THREADS={threads} " + " ".join(args), "out": relative(out),
                  "config": relative(config), "threads": threads}
        key = hashlib.sha256((config.read_text() + self.binary_id + str(threads)).encode()).hexdigest()
        key_file = out.parent / f"{name}.key.json"
        stored = self._cached(key_file, key)
        if stored is None:
            shutil.rmtree(out, ignore_errors=True)
            if not self.vimd_path.exists():
                rc, text, wall = 127, f"vimd binary {self.vimd_path} does not exist", 0.0
            else:
                self.log(f"  {result['command']}")
                rc, text, wall = self._execute(args, out.parent / f"{name}.log", timeout, threads)
            stored = {"key": key, "returncode": rc, "message": _last_words(text) if rc else "", "wall": wall}
            key_file.write_text(json.dumps(stored))
        result["wall_measured"] = stored["wall"]
        self.run_seconds += stored["wall"]
        if stored["returncode"] != 0:
            produced = (out / "energy.csv").exists() and len(energy.read_energy_csv(out / "energy.csv")["time"]) > 0
            rejected = not produced and REJECTION.search(stored["message"])
            result["status"] = "not available" if rejected else "failed"
            result["message"] = stored["message"]
            return result
        return self._vimd_outputs(result, out, stability_fraction)

    def _vimd_outputs(self, result, out, stability_fraction):
        try:
            series = energy.read_energy_csv(out / "energy.csv")
            summary = json.loads((out / "summary.json").read_text())
            stats = energy.energy_statistics(series["time"], series["total"], series["kinetic"], result["atoms"])
        except (OSError, KeyError, ValueError) as e:
            result["status"], result["message"] = "failed", f"unusable output: {e}"
            return result
        result["stats"] = stats
        result["summary"] = summary
        wall = summary.get("wall_seconds", result["wall_measured"])
        evaluations = summary.get("force_evaluations_per_step", float("nan")) + \
            summary.get("hessian_evaluations_per_step", 0.0)
        result["cost"] = {"wall_per_ps": wall / result["ps"], "evaluations_per_step": evaluations,
                          "evaluations_per_ps": evaluations / result["dt"],
                          "mean_iterations": summary.get("mean_iterations")}
        stable = energy.is_stable(stats, stability_fraction)
        result["status"] = "ok" if stable else "unstable"
        result["message"] = "" if stable else (
            f"|E(t) - E(0)| reached {stats['max_excursion']:.3g} kJ/mol > "
            f"{stability_fraction:g} x <E_kin> = {stability_fraction * stats['mean_kinetic']:.3g} kJ/mol")
        return result

    # ---------------------------------------------------------------- GROMACS
    def gromacs(self, system, gv, dt, ps, tag, energy_every, trajectory_every, binary="gmx_d",
                timeout=3600, stability_fraction=0.01):
        steps = int(round(ps / dt))
        name = f"{gv.key}_dt{fs(dt)}fs"
        mdp = self.config_dir / tag / f"{name}.mdp"
        out = self.runs_dir / tag / name
        mdp.parent.mkdir(parents=True, exist_ok=True)
        ff = system.forcefield
        # Pair-list buffer = vimd's neighbour skin, the list rebuilt every 20 fs per 0.1 nm of buffer
        # (GROMACS's automatic buffer is tuned for its own drift target, not for a comparison at
        # many time steps, and must stay below half the small box).
        buffer = ff["neighbor_skin"]
        pme = {key: ff[key] for key in ("ewald_rtol", "pme_order", "fourier_spacing") if key in ff}
        nonbonded = nonbonded_mdp(ff["cutoff"], ff["vdw_modifier"], ff["vdw_switch"], ff.get("epsilon_rf"),
                                  ff["coulomb"], rlist=ff["cutoff"] + buffer, pme=pme)
        nonbonded["nstlist"] = max(1, min(10, int(round(0.2 * buffer / dt))))
        write_mdp(mdp, integrator=gv.integrator, dt=dt, nsteps=steps, nstcalcenergy=energy_every,
                  nstenergy=energy_every, nstlog=0, nstxout=trajectory_every, nstvout=trajectory_every,
                  nstfout=0, comm_mode="None", tcoupl="no", pcoupl="no", gen_vel="no", continuation="no",
                  constraints="none", **nonbonded)
        tpr, deffnm = out / "topol.tpr", out / "gmx"
        grompp = [binary, "grompp", "-f", relative(mdp), "-c", relative(system.structure), "-p",
                  relative(system.topology), "-o", relative(tpr), "-po", relative(out / "mdout.mdp"),
                  "-maxwarn", "3"]
        mdrun = [binary, "mdrun", "-s", relative(tpr), "-deffnm", relative(deffnm), "-nt", str(self.threads),
                 "-pin", "off"]
        result = {"kind": "gromacs", "system": system.name, "variant": gv.key, "label": gv.label, "dt": dt,
                  "steps": steps, "ps": steps * dt, "atoms": system.atoms,
                  "command": " ".join(grompp) + " && " + " ".join(mdrun) +
                             f" && {binary} energy -f {relative(deffnm)}.edr (Total-Energy, Kinetic-En., Temperature)",
                  "out": relative(out), "config": relative(mdp)}
        key = hashlib.sha256((mdp.read_text() + binary + str(self.threads)).encode()).hexdigest()
        key_file = out.parent / f"{name}.key.json"
        stored = self._cached(key_file, key)
        if stored is None:
            shutil.rmtree(out, ignore_errors=True)
            out.mkdir(parents=True)
            self.log(f"  {' '.join(mdrun)}")
            rc, text, _ = self._execute(grompp, out / "grompp.log", 300)
            wall = 0.0
            if rc == 0:
                rc, text, wall = self._execute(mdrun, out / "mdrun.out", timeout)
                log = out / "gmx.log"
                found = re.search(r"^\s+Time:\s+\S+\s+(\S+)", log.read_text(), re.MULTILINE) if log.exists() else None
                wall = float(found.group(1)) if found else wall
            stored = {"key": key, "returncode": rc, "message": _last_words(text) if rc else "", "wall": wall}
            key_file.write_text(json.dumps(stored))
        self.run_seconds += stored["wall"]
        if stored["returncode"] != 0:
            result["status"], result["message"] = "failed", stored["message"]
            return result
        try:
            g = gmx_energy(binary, (out / "gmx.edr").resolve(), ["Total-Energy", "Kinetic-En.", "Temperature"], out)
            np.savez(out / "series.npz", time=g["time"], total=g["Total Energy"], kinetic=g["Kinetic En."],
                     temperature=g["Temperature"])
            stats = energy.energy_statistics(g["time"], g["Total Energy"], g["Kinetic En."], result["atoms"])
        except (RuntimeError, KeyError, ValueError) as e:
            result["status"], result["message"] = "failed", f"unusable output: {e}"
            return result
        result["stats"] = stats
        result["cost"] = {"wall_per_ps": stored["wall"] / result["ps"], "evaluations_per_step": 1.0,
                          "evaluations_per_ps": 1.0 / dt, "mean_iterations": None}
        stable = energy.is_stable(stats, stability_fraction)
        result["status"] = "ok" if stable else "unstable"
        result["message"] = "" if stable else f"|E(t) - E(0)| reached {stats['max_excursion']:.3g} kJ/mol"
        return result

    def gromacs_positions(self, run, structure, at_time, binary="gmx_d"):
        """Full-precision positions (nm) of one trajectory frame via `gmx traj -fp` (MDAnalysis
        reads .trr coordinates in single precision, too coarse for errors down to 1e-10 nm)."""
        out = ROOT / run["out"]
        xvg = out / f"x_at_{at_time:g}.xvg"
        traj = out / ("traj.trr" if run["kind"] == "vimd" else "gmx.trr")
        args = [binary, "traj", "-f", str(traj), "-s", str(structure), "-ox", str(xvg), "-fp", "-nopbc",
                "-b", f"{at_time - 1e-5:.6f}", "-e", f"{at_time + 1e-5:.6f}"]
        p = subprocess.run(args, cwd=out, input="0\n", text=True, capture_output=True, env=gmx_env())
        if p.returncode != 0 or not xvg.exists():
            raise RuntimeError(f"{' '.join(args)} failed: {_last_words(p.stdout + p.stderr)}")
        rows = [l.split() for l in xvg.read_text().splitlines() if l and l[0] not in "#@"]
        if not rows:
            raise RuntimeError(f"no frame at t = {at_time} ps in {traj}")
        row = np.array([float(x) for x in rows[-1]])
        if abs(row[0] - at_time) > 1e-6:
            raise RuntimeError(f"frame at t = {row[0]} ps, wanted {at_time} ps, in {traj}")
        return row[1:].reshape(-1, 3)


def progress(message):
    print(message, file=sys.stderr, flush=True)

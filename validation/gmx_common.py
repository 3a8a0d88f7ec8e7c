"""Shared helpers for the GROMACS cross-checks: write an .mdp, run gmx/gmx_d quietly, read .xvg
series, run vimd, write a results file. Only Debian's /usr/bin/python3 has the packages these
scripts use."""
import datetime
import json
import os
import pathlib
import re
import shlex
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
VIMD = ROOT / "build" / "vimd"
RDTSCP_SHIM = ROOT / "build" / "libgmx_rdtscp_shim.so"
# Every command run() and vimd() ran, as (working directory or None, command line, wall seconds), for
# scripts that print what a user would type to repeat them.
HISTORY = []


def _timed(cmd, cwd, **kwargs):
    start = time.monotonic()
    p = subprocess.run(cmd, cwd=cwd, text=True, capture_output=True, **kwargs)
    HISTORY.append((cwd, " ".join(map(str, cmd)), time.monotonic() - start))
    return p


def cpu_model():
    for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return "unknown CPU"


def gmx_simd(log):
    """The SIMD level a GROMACS build was compiled for, from its log's version block."""
    m = re.search(r"^SIMD instructions:\s*(\S+)", log, re.MULTILINE)
    return m.group(1) if m else "?"


def gmx_env(env=None):
    """The environment for a gmx/gmx_d command. Debian's GROMACS refuses to start when CPUID does
    not advertise rdtscp, which some VMs hide although the instruction works: there the shim built
    next to vimd (validation/gmx_rdtscp_shim.cpp) is preloaded to add the flag."""
    env = dict(os.environ if env is None else env)
    flags = next((line for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines()
                  if line.startswith("flags")), "")
    if "rdtscp" not in flags.split():
        if not RDTSCP_SHIM.is_file():
            raise RuntimeError(f"this CPU hides the rdtscp flag and GROMACS needs {RDTSCP_SHIM}: build it "
                               "(bash app/setup.sh gmx_rdtscp_shim)")
        env["LD_PRELOAD"] = " ".join(filter(None, [env.get("LD_PRELOAD", ""), str(RDTSCP_SHIM)]))
    return env


def run(cmd, cwd, stdin=None):
    """Run a command, raising with its output when it fails. OMP_NUM_THREADS is dropped: mdrun
    refuses it when it disagrees with -nt."""
    env = gmx_env({k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"})
    p = _timed(cmd, cwd, input=stdin, env=env)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({p.returncode}):\n{p.stdout[-3000:]}\n{p.stderr[-3000:]}")
    return p.stdout


def write_mdp(path, **settings):
    path.write_text("".join(f"{k.replace('_', '-')} = {v}\n" for k, v in settings.items()))


def nonbonded_mdp(cutoff, vdw_modifier, vdw_switch, epsilon_rf, coulomb="reaction-field", rlist=None, pme=None):
    """GROMACS settings matching a vimd [forcefield] table, with a fixed pair list of radius rlist
    (default: the cut-off, exact for reruns) rebuilt every 10 steps. coulomb = "pme" takes
    pme = dict(ewald_rtol=..., pme_order=..., fourier_spacing=...) (GROMACS's defaults where absent)."""
    coulombtype = {"reaction-field": "reaction-field", "cutoff": "cut-off", "pme": "PME"}[coulomb]
    s = dict(cutoff_scheme="Verlet", verlet_buffer_tolerance=-1, rlist=rlist or cutoff, nstlist=10,
             coulombtype=coulombtype, rcoulomb=cutoff, vdwtype="cut-off", vdw_modifier=vdw_modifier,
             rvdw=cutoff, DispCorr="no", pbc="xyz")
    if coulomb == "pme":
        s.update(pme or {})
    else:
        s["epsilon_rf"] = epsilon_rf
    if vdw_modifier in ("potential-switch", "force-switch"):
        s["rvdw_switch"] = vdw_switch
    return s


def read_xvg(path):
    """Columns of an .xvg file as lists of floats, and the legends."""
    legends, rows = [], []
    for line in pathlib.Path(path).read_text().splitlines():
        if line.startswith("@") and "legend \"" in line:
            legends.append(line.split("legend \"")[1].rstrip("\""))
        elif line and line[0] not in "#@":
            rows.append([float(x) for x in line.split()])
    return legends, [list(c) for c in zip(*rows)]


def gmx_energy(gmx, edr, terms, cwd):
    """Time series of named energy terms from an .edr file, in full precision (-dp)."""
    out = pathlib.Path(cwd) / "energy_terms.xvg"
    run([gmx, "energy", "-f", edr, "-o", out, "-dp"], cwd, stdin="\n".join(terms) + "\n\n")
    legends, cols = read_xvg(out)
    return {name: cols[k + 1] for k, name in enumerate(legends)} | {"time": cols[0]}


def vimd_config(path, structure, topology, forcefield, integrator=None, output=None, system=None):
    """Write a vimd TOML run file with absolute input paths; `system` adds [system] keys."""
    def table(name, d):
        lines = [f"[{name}]"]
        for k, v in d.items():
            lines.append(f"{k} = {json.dumps(v)}")
        return "\n".join(lines) + "\n"
    text = table("system", {"structure": str(structure), "topology": str(topology), **(system or {})})
    text += table("forcefield", forcefield)
    if integrator:
        text += table("integrator", integrator)
    if output:
        text += table("output", output)
    pathlib.Path(path).write_text(text)


def vimd(*args, threads=None):
    env = dict(os.environ)
    if threads:
        env["OMP_NUM_THREADS"] = str(threads)
    p = _timed([str(VIMD), *map(str, args)], None, env=env)
    if p.returncode != 0:
        raise RuntimeError(f"vimd {' '.join(map(str, args))} failed ({p.returncode}):\n{p.stdout[-3000:]}\n{p.stderr[-3000:]}")
    return p.stdout


# The keys every results file has (validation/results/*.json, turned into validation/README.md's tables
# by validation/tables.py): where its figures come from, and the figures.
RESULTS_KEYS = ("question", "command", "commit", "cpu", "simd", "date", "rows")


def git_commit():
    """HEAD's short hash, with -dirty when tracked files differ from it."""
    def git(*args):
        return subprocess.run(["git", "-C", str(ROOT), *args], text=True, capture_output=True)
    head = git("rev-parse", "--short", "HEAD")
    if head.returncode:
        return "unknown"
    return head.stdout.strip() + ("-dirty" if git("diff", "--quiet", "HEAD", "--").returncode else "")


def results_start(question):
    """A results file's provenance, taken when the measurement starts, so that the commit is the code
    measured even if the tree changes meanwhile. The caller adds the SIMD targets that ran and the rows."""
    script = pathlib.Path(sys.argv[0]).resolve()
    name = str(script.relative_to(ROOT)) if script.is_relative_to(ROOT) else str(script)
    command = shlex.join((["/usr/bin/python3"] if name.endswith(".py") else []) + [name, *sys.argv[1:]])
    return dict(question=question, command=command, commit=git_commit(), cpu=cpu_model(), simd="unknown",
                date=datetime.date.today().isoformat())


def write_results(path, results):
    """Replace a results file: a line per key, and one per row, so that a rerun's diff shows which
    figures moved."""
    missing = [k for k in RESULTS_KEYS if k not in results]
    if missing:
        raise ValueError(f"results for {path} lack {', '.join(missing)}")
    lines = [f" {json.dumps(k)}: {json.dumps(v, ensure_ascii=False)}" for k, v in results.items() if k != "rows"]
    rows = ",\n".join(f"  {json.dumps(row, ensure_ascii=False)}" for row in results["rows"])
    lines.append(f' "rows": [\n{rows}\n ]' if rows else ' "rows": []')
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    partial.write_text("{\n" + ",\n".join(lines) + "\n}\n")
    partial.replace(path)


def sci(x, digits=1, sign=False):
    """x in scientific notation without the exponent's padding, as the tables write it: 3.1e-9."""
    return re.sub(r"e([+-])0*(\d)", r"e\1\2", f"{x:{'+' if sign else ''}.{digits}e}")

#!/usr/bin/python3
"""The bad-input catalogue: every directory of tests/bad_inputs/ (except _shared) is one case.

A case holds run.toml, the files it needs (paths may point into ../_shared), an optional setup.sh
(run with bash inside the scratch copy first) and expect.txt with the lines
    command: run|check|energy      the vimd subcommand, applied to run.toml
    exit: nonzero | <number>       nonzero: any ordinary failure (not a signal); 0 for a warning
    message: <fragment>            must appear in stderr (several message lines: all must)
('#' lines are comments). For `run` the runner adds `--out out`. After a failed run no file but
*.partial may exist under out/. Every message must end with a newline.

Usage: bad_inputs.py VIMD CATALOGUE_DIR WORK_DIR [CASE...]
"""
import os
import shutil
import subprocess
import sys
from pathlib import Path


def read_expectation(file):
    expect = {"message": []}
    for number, line in enumerate(file.read_text().splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        key, sep, value = line.partition(":")
        key, value = key.strip(), value.strip()
        if not sep or key not in ("command", "exit", "message"):
            raise ValueError(f"{file}:{number}: expected 'command:', 'exit:' or 'message:', got {line!r}")
        if key == "message":
            expect["message"].append(value)
        else:
            expect[key] = value
    for key in ("command", "exit"):
        if key not in expect:
            raise ValueError(f"{file}: no '{key}:' line")
    if expect["command"] not in ("run", "check", "energy"):
        raise ValueError(f"{file}: command must be run, check or energy, not {expect['command']!r}")
    if not expect["message"]:
        raise ValueError(f"{file}: no 'message:' line")
    return expect


def run_case(vimd, case_dir, work):
    """Returns (ok, exit code, problem or first stderr line)."""
    expect = read_expectation(case_dir / "expect.txt")
    scratch = work / case_dir.name
    shutil.copytree(case_dir, scratch)
    if (scratch / "setup.sh").exists():
        setup = subprocess.run(["bash", "setup.sh"], cwd=scratch, capture_output=True, text=True, timeout=60)
        if setup.returncode != 0:
            return False, None, f"setup.sh failed: {setup.stderr.strip()}"
    before = set((scratch / "out").rglob("*")) if (scratch / "out").exists() else set()
    command = [vimd, expect["command"], "run.toml"] + (["--out", "out"] if expect["command"] == "run" else [])
    try:
        result = subprocess.run(command, cwd=scratch, capture_output=True, text=True, timeout=120,
                                env=dict(os.environ, OMP_NUM_THREADS="1"))
    except subprocess.TimeoutExpired:
        return False, None, "timed out after 120 s"
    rc, stderr = result.returncode, result.stderr
    first = next((l for l in stderr.splitlines() if l.strip()), "(no message)")
    if expect["exit"] == "nonzero":
        if rc <= 0:
            return False, rc, f"wanted a failure exit, got {rc}; stderr: {first}"
    elif rc != int(expect["exit"]):
        return False, rc, f"wanted exit {expect['exit']}, got {rc}; stderr: {stderr.strip()}"
    missing = [m for m in expect["message"] if m not in stderr]
    if missing:
        return False, rc, f"stderr lacks {missing!r}; stderr: {stderr.strip()}"
    if stderr and not stderr.endswith("\n"):
        return False, rc, "the message does not end with a newline"
    # Files the command wrote (not the case's setup), other than .partial outputs and the kept last
    # good frame of a blown-up run, would pass for a finished run's output.
    if rc != 0 and expect["command"] == "run" and (scratch / "out").exists():
        left = [str(p.relative_to(scratch)) for p in (scratch / "out").rglob("*")
                if p.is_file() and p not in before and not p.name.endswith(".partial")
                and p.name != "last_good.gro"]
        if left:
            return False, rc, f"a failed run left output not marked .partial: {', '.join(sorted(left))}"
    # Show the line that carries the expected fragment.
    shown = next((l for l in stderr.splitlines() if expect["message"][0] in l), first)
    return True, rc, shown


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    vimd, catalogue, work = os.path.abspath(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    only = set(sys.argv[4:])
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    if (catalogue / "_shared").exists():
        shutil.copytree(catalogue / "_shared", work / "_shared")
    cases = sorted(d for d in catalogue.iterdir()
                   if d.is_dir() and not d.name.startswith("_") and (not only or d.name in only))
    if only - {d.name for d in cases}:
        sys.exit(f"no such case: {', '.join(sorted(only - {d.name for d in cases}))}")
    width = max(len(d.name) for d in cases)
    failures = 0
    print(f"{'case':<{width}}  exit  result  message")
    for case_dir in cases:
        try:
            ok, rc, text = run_case(vimd, case_dir, work)
        except (ValueError, OSError, subprocess.SubprocessError) as e:
            ok, rc, text = False, None, str(e)
        failures += not ok
        print(f"{case_dir.name:<{width}}  {'-' if rc is None else rc:>4}  {'ok' if ok else 'FAIL':<6}  {text[:200]}")
    print(f"{len(cases) - failures} of {len(cases)} bad-input cases passed")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()

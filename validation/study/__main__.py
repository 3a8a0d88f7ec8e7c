"""Run the validation study and write its report.

    validation/run_all.sh [--quick] [--out DIR] [--runs DIR] [--vimd PATH] [--threads N] [--reuse]
                          [--sections scan,order,long,smooth,pme]

Full study (~1 h 40 min without section 7: sections 1-5 ~1 h at one thread, section 6 "Smooth
interactions" ~40 min at two threads; section 7 "PME water", estimated 1-1.5 h at two threads, has not
run in full yet): report in validation/report/, run outputs in build/study-runs/.
--quick:    a smoke test of every section with tiny runs; report in build/report-quick/ (or --out),
            so the committed full report is never overwritten by tests.
"""
import argparse
import datetime
import json
import os
import pathlib
import shutil
import subprocess
import sys
import time

from gmx_common import ROOT
from . import report, sections
from .engines import Runner, progress
from .plan import FS, FULL, QUICK, relative


def git_state():
    def git(*args):
        return subprocess.run(["git", *args], cwd=ROOT, text=True, capture_output=True).stdout.strip()
    rev = git("rev-parse", "--short", "HEAD") or "unknown"
    # The report's own files are being rewritten by this run: they do not make the source dirty.
    dirty = git("status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)validation/report")
    return rev + (" (with uncommitted changes)" if dirty else "")


def load():
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def clean_report_dir(path):
    """Remove what a previous run of the study wrote (and nothing else)."""
    for child in ("configs",):
        shutil.rmtree(path / child, ignore_errors=True)
    for pattern in ("*.png", "README.md", "results.json"):
        for f in path.glob(pattern):
            f.unlink()


def main():
    ap = argparse.ArgumentParser(description="vimd validation study (issue 4)")
    ap.add_argument("--quick", action="store_true", help="smoke test: tiny runs of every section (< 5 min)")
    ap.add_argument("--out", type=pathlib.Path, help="report directory (default validation/report, "
                    "or build/report-quick with --quick)")
    ap.add_argument("--runs", type=pathlib.Path,
                    help="run outputs (default build/study-runs, or OUT/runs with --quick)")
    ap.add_argument("--vimd", type=pathlib.Path, default=pathlib.Path(os.environ.get("VIMD", ROOT / "build" / "vimd")),
                    help="the vimd program (default build/vimd or $VIMD)")
    ap.add_argument("--threads", type=int, default=1,
                    help="OpenMP threads per run (default 1: on a shared machine two threads per run can be "
                         "several times slower, and one thread compares every integrator on equal footing); "
                         "section 6 (smooth) runs at its plan's own count, 2, at which its crossover is stated")
    ap.add_argument("--vimd-source", default="",
                    help="where the vimd binary was built from, for the report (e.g. 'git 3b2245f, clean export')")
    ap.add_argument("--reuse", action="store_true",
                    help="reuse a run whose config, binary and thread count are unchanged (development aid)")
    ap.add_argument("--sections", default="scan,order,long,smooth,pme,polymer",
                    help="comma-separated subset of scan,order,long,smooth,pme,polymer (long includes the MDAnalysis "
                         "analyses; smooth compares its switched run with long's GROMACS run when long is run)")
    args = ap.parse_args()

    if not args.vimd.is_file():
        sys.exit(f"study: vimd program {args.vimd} not found (build it: bash app/setup.sh, or pass --vimd PATH)")
    plan = QUICK if args.quick else FULL
    default_report = ROOT / "build" / "report-quick" if args.quick else ROOT / "validation" / "report"
    report_dir = (args.out or default_report).resolve()
    runs_dir = (args.runs or (report_dir / "runs" if args.quick else ROOT / "build" / "study-runs")).resolve()
    report_dir.mkdir(parents=True, exist_ok=True)
    runs_dir.mkdir(parents=True, exist_ok=True)
    clean_report_dir(report_dir)
    wanted = set(args.sections.split(","))
    known = ("scan", "order", "long", "smooth", "pme", "polymer")
    unknown = wanted - set(known)
    if unknown:
        sys.exit(f"study: unknown section(s) {', '.join(sorted(unknown))} in --sections ({', '.join(known)})")

    start, load_before = time.monotonic(), load()
    runner = Runner(args.vimd, report_dir, runs_dir, args.threads, args.reuse, log=progress)
    vimd_state = (f"built {datetime.datetime.fromtimestamp(args.vimd.stat().st_mtime):%Y-%m-%d %H:%M}"
                  if args.vimd.exists() else "missing")
    progress(f"study: {'quick' if plan.quick else 'full'} mode, report in {report_dir}, runs in {runs_dir}")

    scan = sections.scan(runner, plan, report_dir, progress) if "scan" in wanted else {}
    order = sections.order(runner, plan, report_dir, progress) if "order" in wanted else None
    long = sections.long_runs(runner, plan, report_dir, progress) if "long" in wanted else None
    md = sections.mdanalysis(long, report_dir, progress) if long else None
    smooth = sections.smooth(runner, plan, report_dir, progress, long) if "smooth" in wanted else None
    pme = sections.pme(runner, plan, report_dir, progress) if "pme" in wanted else None
    polymer = sections.polymer(runner, plan, report_dir, progress) if "polymer" in wanted else None

    command = "validation/run_all.sh" + "".join(f" {a}" for a in sys.argv[1:])
    meta = {"command": command, "date": f"{datetime.datetime.now():%Y-%m-%d %H:%M}", "git": git_state(),
            "vimd": relative(args.vimd), "threads": args.threads, "reuse": args.reuse,
            "vimd_state": f"{args.vimd_source}, {vimd_state}" if args.vimd_source else vimd_state,
            "run_minutes": runner.run_seconds / 60,
            "minutes": (time.monotonic() - start) / 60, "load_before": load_before, "load_after": load(),
            "runs": relative(runs_dir), "closing_dts": {"water900": 2 * FS, "polymer": 10 * FS}}
    report.write(report_dir / "README.md", plan, meta, scan, order, long, md, smooth, pme, polymer)
    (report_dir / "results.json").write_text(json.dumps(
        {"meta": meta, "quick": plan.quick, "scan": scan, "order": order, "long": long, "mdanalysis": md,
         "smooth": smooth, "pme": pme, "polymer": polymer},
        indent=1, default=str))
    progress(f"study: wrote {report_dir / 'README.md'} in {meta['minutes']:.1f} min")
    return 0


if __name__ == "__main__":
    sys.exit(main())

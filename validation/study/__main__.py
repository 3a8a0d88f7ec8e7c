"""Run the validation study and write its report.

    validation/run_all.sh [--quick] [--out DIR] [--runs DIR] [--vimd PATH] [--threads N] [--reuse]
                          [--sections scan,order,long,smooth,pme,polymer]

Full study: sections 1-5 about 1 h at one thread, sections 6-8 about 2 h at two threads; report in
validation/report/, run outputs in build/study-runs/. --sections reruns some sections and keeps the others.
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


# What each section writes into the report directory (globs). Section 6's price of smoothness is
# measured only when section 4 runs too (it compares with section 4's GROMACS run).
SECTION_FILES = {
    "scan": ("configs/scan-*", "scan_*.png", "work_precision_*.png"),
    "order": ("configs/order-*", "order_*.png"),
    "long": ("configs/long-*", "long_runs.png", "rdf_oo.png", "constraint_deviations.png", "msd.png",
             "temperature.png"),
    "smooth": ("configs/smooth-*-C[0-9]*", "configs/tolerance-*", "smooth_rms.png", "smooth_work_precision.png"),
    "pme": ("configs/pme-*", "pme_*.png"),
    "polymer": ("configs/polymer-*", "polymer_*.png"),
}
PRICE_OF_SMOOTHNESS_FILES = ("configs/smooth-price-*", "smooth_rdf_oo.png", "smooth_msd.png")
SECTIONS = tuple(SECTION_FILES)


def clean_report_dir(path, sections):
    """Remove what a previous run of the study wrote for these sections (and nothing else). The report and
    results.json stay until the new ones replace them: they hold the sections kept."""
    patterns = [p for section in sections for p in SECTION_FILES[section]]
    if {"smooth", "long"} <= set(sections):
        patterns += PRICE_OF_SMOOTHNESS_FILES
    for pattern in patterns:
        for f in path.glob(pattern):
            if f.is_dir():
                shutil.rmtree(f)
            else:
                f.unlink()


def earlier_results(path, quick):
    """The sections of the report's previous results.json (same mode), each with where its data came from, so a
    run of some sections keeps the others instead of dropping them."""
    try:
        previous = json.loads((path / "results.json").read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return {}
    if previous.get("quick") != quick:
        return {}
    meta = previous.get("meta", {})
    provenance = meta.get("provenance", {})
    kept = {}
    for section in SECTIONS:
        data = previous.get(section)
        if data:
            kept[section] = {"data": data, "mdanalysis": previous.get("mdanalysis") if section == "long" else None,
                             "provenance": provenance.get(section) or {k: meta.get(k) for k in
                                                                     ("command", "date", "git", "vimd_state")}}
    return kept


def keep_price_of_smoothness(smooth, earlier):
    """Section 6's price of smoothness needs section 4's GROMACS run: without it, the earlier measurement
    stays, marked with where it came from."""
    if "skipped" in smooth["price"] and earlier and "skipped" not in earlier["data"].get("price", {"skipped": ""}):
        smooth["price"] = earlier["data"]["price"] | {"kept_from": earlier["data"]["price"].get("kept_from")
                                                      or earlier["provenance"]}


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
                         "analyses; smooth compares its switched run with long's GROMACS run when long is run); the "
                         "report keeps the other sections from its previous results.json and names where they came from")
    args = ap.parse_args()

    if not args.vimd.is_file():
        sys.exit(f"study: vimd program {args.vimd} not found (build it: bash app/setup.sh, or pass --vimd PATH)")
    plan = QUICK if args.quick else FULL
    default_report = ROOT / "build" / "report-quick" if args.quick else ROOT / "validation" / "report"
    report_dir = (args.out or default_report).resolve()
    runs_dir = (args.runs or (report_dir / "runs" if args.quick else ROOT / "build" / "study-runs")).resolve()
    wanted = set(args.sections.split(","))
    unknown = wanted - set(SECTIONS)
    if unknown:
        sys.exit(f"study: unknown section(s) {', '.join(sorted(unknown))} in --sections ({', '.join(SECTIONS)})")
    report_dir.mkdir(parents=True, exist_ok=True)
    runs_dir.mkdir(parents=True, exist_ok=True)
    earlier = earlier_results(report_dir, plan.quick)
    kept = {k: v for k, v in earlier.items() if k not in wanted}
    clean_report_dir(report_dir, [k for k in SECTIONS if k not in kept])

    start, load_before = time.monotonic(), load()
    runner = Runner(args.vimd, report_dir, runs_dir, args.threads, args.reuse, log=progress)
    vimd_state = (f"built {datetime.datetime.fromtimestamp(args.vimd.stat().st_mtime):%Y-%m-%d %H:%M}"
                  if args.vimd.exists() else "missing")
    progress(f"study: {'quick' if plan.quick else 'full'} mode, report in {report_dir}, runs in {runs_dir}")

    fresh = {"scan": sections.scan(runner, plan, report_dir, progress) if "scan" in wanted else None,
             "order": sections.order(runner, plan, report_dir, progress) if "order" in wanted else None,
             "long": sections.long_runs(runner, plan, report_dir, progress) if "long" in wanted else None}
    fresh["mdanalysis"] = sections.mdanalysis(fresh["long"], report_dir, progress) if fresh["long"] else None
    if "smooth" in wanted:
        fresh["smooth"] = sections.smooth(runner, plan, report_dir, progress, fresh["long"])
        keep_price_of_smoothness(fresh["smooth"], earlier.get("smooth"))
    if "pme" in wanted:
        fresh["pme"] = sections.pme(runner, plan, report_dir, progress)
    if "polymer" in wanted:
        fresh["polymer"] = sections.polymer(runner, plan, report_dir, progress)

    command = "validation/run_all.sh" + "".join(f" {a}" for a in sys.argv[1:])
    this_run = {"command": command, "date": f"{datetime.datetime.now():%Y-%m-%d %H:%M}", "git": git_state(),
                "vimd_state": f"{args.vimd_source}, {vimd_state}" if args.vimd_source else vimd_state}
    results = {section: fresh.get(section) for section in SECTIONS} | {"mdanalysis": fresh["mdanalysis"]}
    provenance = {section: this_run for section in wanted}
    for section, earlier in kept.items():
        results[section] = earlier["data"]
        provenance[section] = earlier["provenance"]
        if section == "long":
            results["mdanalysis"] = earlier["mdanalysis"]
    meta = this_run | {
        "vimd": relative(args.vimd), "threads": args.threads, "reuse": args.reuse,
        "run_minutes": runner.run_seconds / 60,
        "minutes": (time.monotonic() - start) / 60, "load_before": load_before, "load_after": load(),
        "runs": relative(runs_dir), "closing_dts": {"water900": 2 * FS, "polymer": 10 * FS},
        "provenance": provenance, "kept": sorted(kept, key=SECTIONS.index)}
    report.write(report_dir / "README.md", plan, meta, results["scan"] or {}, results["order"], results["long"],
                 results["mdanalysis"], results["smooth"], results["pme"], results["polymer"])
    (report_dir / "results.json").write_text(json.dumps({"meta": meta, "quick": plan.quick} | results,
                                                        indent=1, default=str))
    progress(f"study: wrote {report_dir / 'README.md'} in {meta['minutes']:.1f} min")
    return 0


if __name__ == "__main__":
    sys.exit(main())

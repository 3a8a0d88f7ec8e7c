#!/usr/bin/python3
"""Smoke test of the validation study's report: its numbers parse and lie in sane ranges.

    /usr/bin/python3 validation/check_report.py REPORT_DIR
    /usr/bin/python3 validation/check_report.py --run-quick --out DIR [--vimd PATH]

The second form first runs `validation/run_all.sh --quick --out DIR` (the test command does this).
Checks: every section and figure is there (real, non-trivial PNGs); every integrator the study asks
for has a row (available or "not available in this build", never dropped); every table row with
numbers names its command; no NaN; and physical sanity: RATTLE and GROMACS at 2 fs conserve energy
(|drift| < 0.05 kJ/mol/ps/atom, 0 < RMS fluctuation < 50 kJ/mol), the O-O RDF peaks at 0.26-0.30 nm
with height 2-4.5, temperatures 250-350 K, diffusion coefficients 1e-6-3e-4 cm²/s, the observed
order of RATTLE and gmx md-vv 1.5-2.6 (of SHAKE and gmx md 0.8-2.6: leap-frog started from
v(-dt/2) is first order), of RATTLE's compositions within nominal ± 0.3 (their steps are chosen
above the round-off floor), of the other methods within [nominal - 1, nominal + 1.5]; in section 6
(smooth interactions) RATTLE's slope of RMS fluctuation vs dt 1.5-2.6 at every smoothness, the
others' in [0.5, nominal + 1.5] (the smoothness may cap them), every RATTLE/vi time ratio positive,
a crossover statement, and the switched run's RDF peak, RDF difference to GROMACS (< 0.5) and D;
in section 7 (PME water) the same slope ranges, a crossover statement and the price of smoothness
(three runs compared, the change stated); in section 8 (the alkane melt) slopes and a crossover statement.
Exit status 1 with the list of failures otherwise.
"""
import argparse
import pathlib
import re
import subprocess
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from study.plan import COMPOSITION_ORDERS, GMX_VARIANTS, SCAN_VARIANTS, TABLEAU_ORDERS  # noqa: E402

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
NOT_AVAILABLE = "not available in this build"


def parse_tables(markdown):
    """(section heading, header cells, rows of cells) for every pipe table."""
    tables, heading, lines = [], "", markdown.splitlines()
    k = 0
    while k < len(lines):
        line = lines[k]
        if line.startswith("#"):
            heading = line.lstrip("#").strip()
        if line.startswith("|") and k + 1 < len(lines) and re.match(r"^\|(-+\|)+$", lines[k + 1].strip()):
            header = split_row(line)
            rows = []
            k += 2
            while k < len(lines) and lines[k].startswith("|"):
                rows.append(split_row(lines[k]))
                k += 1
            tables.append((heading, header, rows))
            continue
        k += 1
    return tables


def split_row(line):
    cells = re.split(r"(?<!\\)\|", line.strip())[1:-1]
    return [c.strip().replace("\\|", "|") for c in cells]


def number(cell):
    try:
        return float(cell.strip("*` "))
    except ValueError:
        return None


def magnitude(cell):
    value = number(cell)
    return None if value is None else abs(value)


class Checker:
    def __init__(self):
        self.failures, self.notes = [], []

    def check(self, condition, message):
        if not condition:
            self.failures.append(message)
        return condition

    def in_range(self, value, lo, hi, what):
        return self.check(value is not None and lo <= value <= hi, f"{what} = {value} not in [{lo}, {hi}]")


def check_slopes(c, rows, where):
    """Sections 6 and 7: a RATTLE row at every level, its slope of RMS fluctuation vs dt 1.5-2.6, the
    others' in [0.5, nominal + 1.5] (the smoothness may cap them)."""
    for level in {row[0] for row in rows}:
        c.check(any(r[0] == level and r[1] == "rattle" for r in rows), f"no rattle row at {level}{where}")
    for row in rows:
        slope, nominal = number(row[3]), int(row[2])
        if row[1] == "rattle":
            c.in_range(slope, 1.5, 2.6, f"slope of RMS fluctuation vs dt of rattle at {row[0]}{where}")
        elif slope is not None:
            c.in_range(slope, 0.5, nominal + 1.5, f"slope of RMS fluctuation vs dt of {row[1]} at {row[0]}{where}")
        else:
            c.check(row[3].startswith("n/a"), f"slope of {row[1]} at {row[0]}{where}: unexpected '{row[3]}'")


def check_report(report_dir):
    c = Checker()
    readme = report_dir / "README.md"
    if not readme.exists():
        c.failures.append(f"{readme} does not exist")
        return c
    text = readme.read_text()
    for heading in ("## 1. Energy drift", "## 2. Work-precision", "## 3. Order study", "## 4. Long runs",
                    "## 5. MDAnalysis analyses", "## 6. Smooth interactions", "## 7. PME water",
                    "## 8. Real polymers", "## Closing note"):
        c.check(heading in text, f"section '{heading}' missing")
    for image in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        png = report_dir / image
        ok = png.exists() and png.read_bytes()[:8] == PNG_SIGNATURE and png.stat().st_size > 5000
        c.check(ok, f"figure {image} missing, not a PNG or nearly empty")
    c.check(not re.search(r"\|\s*nan\s*\|", text, re.IGNORECASE), "a table cell is NaN")

    tables = parse_tables(text)
    # Every integrator of the study has a row in the availability table: available or rejected.
    avail = [t for t in tables if t[1][:1] == ["integrator"] and any(h.startswith("scan ") for h in t[1])]
    if c.check(len(avail) == 1, "availability table missing"):
        _, header, rows = avail[0]
        labels = {r[0]: r[1:] for r in rows}
        for v in SCAN_VARIANTS + GMX_VARIANTS:
            c.check(v.label in labels, f"integrator '{v.label}' has no row in the availability table")
        for cells in labels.get("rattle", []):
            c.check(cells == "available", f"rattle must be available everywhere, found: {cells}")
        for label, cells in labels.items():
            for col, cell in zip(header[1:], cells):
                c.check(cell in ("available", "-") or cell.startswith(f"**{NOT_AVAILABLE}**"),
                        f"availability of {label} in {col}: unexpected '{cell}'")
                if cell.startswith(f"**{NOT_AVAILABLE}**"):
                    c.notes.append(f"{label} ({col}): {cell}")

    # Rows with numbers name their command.
    for heading, header, rows in tables:
        if "command" not in header[-1] and "commands" not in header[-1]:
            continue
        for row in rows:
            if any(cell.startswith("not run") for cell in row):
                continue  # a step skipped after an unstable one: its dt is the only number
            has_numbers = any(number(cell) is not None for cell in row[1:-1])
            if has_numbers:
                c.check(row[-1].startswith("`") and ("vimd" in row[-1] or "gmx" in row[-1]),
                        f"row '{row[0]}' in a table under '{heading}' shows numbers but no command")

    # Closing note: RATTLE and GROMACS at 2 fs on water900.
    closing = [t for t in tables if t[0] == "Closing note" and "drift (kJ/mol/ps/atom)" in t[1]]
    c.check(closing, "closing note has no drift/fluctuation table")
    for _, header, rows in closing[:1]:
        drift, fluct = header.index("drift (kJ/mol/ps/atom)"), header.index("RMS fluct. (kJ/mol)")
        for label in ("rattle",) + tuple(v.label for v in GMX_VARIANTS):
            row = next((r for r in rows if r[0] == label), None)
            if c.check(row is not None, f"closing note: no row for {label}"):
                c.check(row[1] == "stable", f"closing note: {label} at 2 fs is '{row[1]}', expected stable")
                c.in_range(magnitude(row[drift]), 0, 0.05, f"closing note: |drift| of {label}")
                c.in_range(number(row[fluct]), 1e-6, 50, f"closing note: RMS fluctuation of {label}")
        for row in rows:
            if row[1] == "stable":
                c.in_range(magnitude(row[drift]), 0, 0.5, f"closing note: |drift| of {row[0]}")

    # All stable runs of the scans: finite, positive fluctuation, bounded drift.
    for heading, header, rows in tables:
        if header[:3] != ["integrator", "dt (fs)", "status"]:
            continue
        for row in rows:
            if row[2] == "stable":
                c.in_range(number(row[4]), 1e-12, 1e3, f"RMS fluctuation of {row[0]} at {row[1]} fs ({heading})")
                c.in_range(magnitude(row[3]), 0, 1.0, f"|drift| of {row[0]} at {row[1]} fs ({heading})")

    # MDAnalysis tables.
    def column(needle):
        found = [(h, r) for _, h, r in tables if any(needle in x for x in h)]
        return found[0] if found else (None, [])

    header, rows = column("first peak r (nm)")
    c.check(rows, "no RDF table")
    for row in rows:
        c.in_range(number(row[2]), 0.26, 0.30, f"RDF first peak position of {row[0]} (nm)")
        c.in_range(number(row[3]), 2.0, 4.5, f"RDF first peak height of {row[0]}")
    header, rows = column("mean T, MDAnalysis (K)")
    c.check(rows, "no temperature table")
    for row in rows:
        c.in_range(number(row[1]), 250, 350, f"temperature (MDAnalysis) of {row[0]}")
        c.in_range(number(row[2]), 250, 350, f"temperature (engine) of {row[0]}")
    header, rows = column("D (cm²/s)")
    c.check(rows, "no diffusion table")
    for row in rows:
        c.in_range(number(row[1]), 1e-6, 3e-4, f"diffusion coefficient of {row[0]} (cm²/s)")

    # Order study.
    header, rows = column("fitted slope")
    c.check(rows, "no order-study table")
    for row in rows:
        slope, nominal = number(row[2]), int(row[1])
        if row[0] in ("rattle", GMX_VARIANTS[0].label):
            c.in_range(slope, 1.5, 2.6, f"observed order of {row[0]}")
        elif row[0] in ("shake", GMX_VARIANTS[1].label) and slope is not None:
            # leap-frog positions are first order from the start when the input velocity is taken as
            # v(-dt/2), as GROMACS does; second order when it is taken as v(0)
            c.in_range(slope, 0.8, 2.6, f"observed order of {row[0]}")
        elif row[0].split()[1:] and row[0].split()[1] in COMPOSITION_ORDERS:
            c.in_range(slope, nominal - 0.3, nominal + 0.3, f"observed order of {row[0]} (nominal {nominal})")
        elif slope is not None:
            c.in_range(slope, nominal - 1.0, nominal + 1.5, f"observed order of {row[0]} (nominal {nominal})")
        else:
            c.check(row[2].startswith(f"**{NOT_AVAILABLE}") or row[2].startswith("n/a"),
                    f"order of {row[0]}: unexpected '{row[2]}'")
    c.check(set(TABLEAU_ORDERS) >= {m.split()[1] for m in (r[0] for r in rows) if m.startswith(("vi ", "rk "))},
            "order study lists an unknown method")

    # Section 6: slopes of RMS fluctuation vs dt, RATTLE's equivalent cost, the price of smoothness.
    header, rows = column("slope of RMS vs dt")
    c.check(rows, "no smooth-interactions slope table")
    check_slopes(c, rows, "")
    for ratio, what in (("best RATTLE time / its time", "RATTLE"), ("best peer time / vi time", "best peer")):
        header, rows = column(ratio)
        c.check(rows, f"no smooth-interactions crossover table against {what}")
        for row in rows:
            c.check(row[2] == "n/a" or (magnitude(row[2]) or 0) > 0, f"{what} / vi time ratio of {row[1]}: '{row[2]}'")
    header, rows = column("best peer time / best vi time")
    c.check(rows, "no smooth-interactions work-precision table at equal accuracy")
    smooth_text = text.split("## 6. Smooth interactions")[-1].split("## 7. PME water")[0]
    c.check("**Crossover:**" in smooth_text, "section 6 states no crossover")
    header, rows = column("RMS RDF difference to GROMACS")
    c.check(rows, "no price-of-smoothness table")
    for row in rows:
        c.in_range(number(row[header.index("first peak r (nm)")]), 0.26, 0.30,
                   f"RDF first peak position of {row[0]} (price of smoothness)")
        cell = row[header.index("RMS RDF difference to GROMACS")]
        if cell != "(reference)":
            c.in_range(number(cell), 0, 0.5, f"RMS RDF difference of {row[0]} to GROMACS")
        c.in_range(number(row[header.index("D ± error (cm²/s)")].split("±")[0]), 1e-6, 3e-4,
                   f"diffusion coefficient of {row[0]} (price of smoothness)")

    # Section 7: the same comparison on PME water.
    pme_text = text.split("## 7. PME water")[-1].split("## 8. Real polymers")[0]
    c.check("**Crossover:**" in pme_text, "section 7 states no crossover")
    slopes = [row for _, h, rows in parse_tables(pme_text) if "slope of RMS vs dt" in h for row in rows]
    c.check(slopes, "no PME-water slope table")
    check_slopes(c, slopes, " (PME)")
    structure = [(h, row) for _, h, rows in parse_tables(pme_text) if "RMS RDF difference to GROMACS" in h
                 for row in rows]
    c.check(len(structure) == 3, f"section 7's price of smoothness compares {len(structure)} runs, not 3")
    for header, row in structure:
        c.in_range(number(row[header.index("first peak r (nm)")]), 0.26, 0.30, f"RDF first peak of {row[0]} (PME)")
        cell = row[header.index("RMS RDF difference to GROMACS")]
        if cell != "(reference)":
            c.in_range(number(cell), 0, 0.5, f"RMS RDF difference of {row[0]} to GROMACS (PME)")
        c.in_range(number(row[header.index("D ± error (cm²/s)")].split("±")[0]), 1e-6, 3e-4,
                   f"diffusion coefficient of {row[0]} (PME)")
    c.check("changes the O-O RDF by" in pme_text, "section 7 states no price of smoothness")

    # Section 8: the same comparison on the alkane melt.
    polymer_text = text.split("## 8. Real polymers")[-1].split("## Closing note")[0]
    c.check("**Crossover:**" in polymer_text, "section 8 states no crossover")
    slopes = [row for _, h, rows in parse_tables(polymer_text) if "slope of RMS vs dt" in h for row in rows]
    c.check(slopes, "no real-polymer slope table")
    check_slopes(c, slopes, " (alkane melt)")
    return c


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("report", nargs="?", type=pathlib.Path, help="report directory to check")
    ap.add_argument("--run-quick", action="store_true", help="run validation/run_all.sh --quick first")
    ap.add_argument("--out", type=pathlib.Path, help="report directory for --run-quick")
    ap.add_argument("--vimd", type=pathlib.Path, help="vimd program for --run-quick")
    args = ap.parse_args()
    report_dir = args.report or args.out
    if report_dir is None:
        ap.error("give a report directory (or --out with --run-quick)")
    if args.run_quick:
        cmd = [str(HERE / "run_all.sh"), "--quick", "--out", str(report_dir)]
        if args.vimd:
            cmd += ["--vimd", str(args.vimd)]
        print("check_report:", " ".join(cmd), flush=True)
        start = time.monotonic()
        rc = subprocess.run(cmd).returncode
        minutes = (time.monotonic() - start) / 60
        print(f"check_report: quick study took {minutes:.1f} min", flush=True)
        if rc != 0:
            print(f"check_report: the quick study failed (exit {rc})")
            return 1
    c = check_report(report_dir)
    for note in c.notes:
        print(f"note: {note}")
    for failure in c.failures:
        print(f"FAIL: {failure}")
    print(f"check_report: {report_dir / 'README.md'}: "
          + ("OK" if not c.failures else f"{len(c.failures)} failure(s)"))
    return 1 if c.failures else 0


if __name__ == "__main__":
    sys.exit(main())

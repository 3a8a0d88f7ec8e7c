#!/usr/bin/python3
"""Rewrites the tables of validation/README.md from the results files in validation/results/.

A table sits between `<!-- table: NAME ... -->` and `<!-- end table -->`, NAME naming one or more
results files (validation/results/NAME.json, as the measuring scripts write them with --results).
Each file records where its figures come from (command, commit, CPU, SIMD targets, date) and the
figures (rows); the table is followed by that provenance, one line per file. A file with "columns"
gives one table row per row; a speed file (rows with system, coulomb, vimd, peer, threads and ratio)
becomes a matrix: one row per system and Coulomb setting, one column per vimd build and GROMACS peer,
each cell "2 threads / 1 thread", a ratio followed by its rounds' median and range where recorded.
Usage: /usr/bin/python3 validation/tables.py [--check]
  --check: change nothing; exit 1 with a diff if the README's tables differ from what the results
  files give, or if a results file has no table (the test command runs this).
"""
import argparse
import difflib
import json
import pathlib
import re
import sys

from gmx_common import RESULTS_KEYS

HERE = pathlib.Path(__file__).resolve().parent
README = HERE / "README.md"
RESULTS = HERE / "results"
TABLE = re.compile(r"(<!-- table: ([\w ]+) -->\n).*?(<!-- end table -->)", re.DOTALL)
SPEED_KEYS = ("system", "coulomb", "vimd", "peer", "threads", "ratio")


def load(name):
    path = RESULTS / f"{name}.json"
    if not path.is_file():
        sys.exit(f"tables.py: {README.name} names {path.relative_to(HERE.parent)}, which does not exist")
    results = json.loads(path.read_text())
    missing = [k for k in RESULTS_KEYS if k not in results]
    if "columns" not in results:
        missing += [k for row in results["rows"] for k in SPEED_KEYS if k not in row]
    if missing:
        sys.exit(f"tables.py: {path.name} lacks {', '.join(sorted(set(missing)))}")
    return results


def cell(value):
    text = "" if value is None else f"{value:g}" if isinstance(value, float) else str(value)
    return text.replace("|", "\\|")


def markdown(header, rows):
    return [f"| {' | '.join(map(cell, header))} |", "|---" * len(header) + "|"] + \
        [f"| {' | '.join(map(cell, row))} |" for row in rows]


def columns_table(files):
    columns = files[0]["columns"]
    if any(f.get("columns") != columns for f in files):
        sys.exit(f"tables.py: the results files of one table have different columns: {columns}")
    return markdown(columns, [[row.get(c) for c in columns] for f in files for row in f["rows"]])


def by_threads(texts):
    """A matrix cell: its figures at each thread count, the most threads first."""
    return " / ".join(texts[t] for t in sorted(texts, reverse=True))


def speed_table(files):
    """Ratios vimd / GROMACS (ns/day) by system and Coulomb setting against vimd build and peer."""
    cells = {}  # (row label, column label) -> {threads: text}
    for f in files:
        for row in f["rows"]:
            text = f"{row['ratio']:.2f}"
            if "round_median" in row:
                text += f" ({row['round_median']:.2f}, {row['round_min']:.2f}–{row['round_max']:.2f})"
            key = f"{row['system']}, {row['coulomb']}", f"vimd {row['vimd']} / {row['peer']}"
            cells.setdefault(key, {})[row["threads"]] = text
    row_labels = list(dict.fromkeys(r for r, _ in cells))
    column_labels = list(dict.fromkeys(c for _, c in cells))
    return markdown(["system, Coulomb", *column_labels],
                    [[r, *(by_threads(cells.get((r, c), {})) for c in column_labels)] for r in row_labels])


def provenance(f):
    return f"- `{f['command']}`: commit {f['commit']}; CPU {f['cpu']}; SIMD {f['simd']}; {f['date']}."


def table(names):
    files = [load(name) for name in names]
    lines = columns_table(files) if "columns" in files[0] else speed_table(files)
    return "\n".join(lines + [""] + [provenance(f) for f in files]) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 with a diff where the README differs; write nothing")
    args = ap.parse_args()
    text = README.read_text()
    used = set()

    def rewrite(m):
        names = m.group(2).split()
        used.update(names)
        return m.group(1) + table(names) + m.group(3)

    new = TABLE.sub(rewrite, text)
    unused = sorted({p.stem for p in RESULTS.glob("*.json")} - used)
    if unused:
        print(f"tables.py: results files with no table in {README.name}: {', '.join(unused)}")
    if not args.check:
        if new != text:
            README.write_text(new)
        return 1 if unused else 0
    if new != text:
        sys.stdout.writelines(difflib.unified_diff(text.splitlines(True), new.splitlines(True),
                                                   "validation/README.md", "from validation/results"))
        print("tables.py: the README's tables differ from the results files: run /usr/bin/python3 validation/tables.py")
        return 1
    return 1 if unused else 0


if __name__ == "__main__":
    sys.exit(main())

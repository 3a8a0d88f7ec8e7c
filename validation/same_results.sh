#!/usr/bin/env bash
# Fingerprints of a fixed set of short runs: one line per output file, "run/file sha256".
# For restructurings that must not change results: run it with the vimd of both commits and diff
# the two listings (results depend on the thread count, so it always runs at 2 threads).
#   validation/same_results.sh build/vimd /tmp/after > after.txt
set -euo pipefail
vimd=$(realpath "$1")
out=$(realpath -m "$2")
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export OMP_NUM_THREADS=2
rm -rf "$out" && mkdir -p "$out"

# name, input directory, run-file base, steps, then [section] key = value edits of it
runs=(
  "rattle-smooth|water900|run_smooth.toml|60|"
  "vi-rk8-demo|water900|run_vi.toml|8|"
  "shake|water900|run.toml|60|integrator.type=\"shake\""
  "rattle-mixed|water900|run.toml|60|forcefield.precision=\"mixed\""
  "vi-rk4-mixed|water900|run.toml|10|integrator.type=\"vi\";integrator.method=\"rk4\""
  "vi-rk4-double|water900|run.toml|6|integrator.type=\"vi\";integrator.method=\"rk4\";integrator.solver_precision=\"double\""
  "vi-rk4-anderson|water900|run.toml|6|integrator.type=\"vi\";integrator.method=\"rk4\";integrator.acceleration=\"anderson\";integrator.bias=[-0.5,0.5]"
  "order-rk4|cluster8|run.toml|100|integrator.type=\"vi\";integrator.method=\"rk4\";integrator.solver_tolerance=1e-12"
  "order-rk6-sym|cluster8|run.toml|50|integrator.type=\"vi\";integrator.method=\"rk6\";integrator.bias=[-0.5,0.5];integrator.solver_tolerance=1e-12"
  "order-rk-projected|cluster8|run.toml|50|integrator.type=\"rk\";integrator.method=\"rk4\""
  "polymer-rattle|polymer|run.toml|100|"
  "polymer-vi|polymer|run.toml|20|integrator.type=\"vi\";integrator.method=\"rk4\""
  "nvt-rattle|water216|run.toml|60|integrator.thermostat=\"v-rescale\";integrator.temperature=300"
  "pme-rattle|water900|run_pme.toml|30|"
  "pme-mixed|water900|run_pme.toml|30|forcefield.precision=\"mixed\""
  "pme-vi|water900|run_vi_pme.toml|4|"
  "force-switch|water216|run.toml|40|forcefield.vdw_modifier=\"force-switch\";forcefield.vdw_switch=0.6"
  "tip4p-vsites|tip4p2005|run.toml|30|"
  "alkane-dihedrals|alkane|run.toml|20|"
)
for spec in "${runs[@]}"; do
  IFS='|' read -r name input file steps edits <<<"$spec"
  config="$root/inputs/$input/same_results_$name.toml"
  /usr/bin/python3 - "$root/inputs/$input/$file" "$config" "$edits" <<'PY'
import sys, tomllib
src, dst, edits = sys.argv[1:]
cfg = tomllib.load(open(src, "rb"))
for edit in filter(None, edits.split(";")):
    key, value = edit.split("=", 1)
    section, name = key.rsplit(".", 1)
    cfg.setdefault(section, {})[name] = tomllib.loads(f"x = {value}")["x"]
cfg["output"].update(trajectory_every=5, energy_every=1)
def value(v):
    if isinstance(v, str): return f'"{v}"'
    if isinstance(v, bool): return str(v).lower()
    if isinstance(v, list): return "[" + ", ".join(value(x) for x in v) + "]"
    return repr(v)
with open(dst, "w") as f:
    for section, table in cfg.items():
        f.write(f"[{section}]\n" + "".join(f"{k} = {value(v)}\n" for k, v in table.items()))
PY
  "$vimd" run "$config" --steps "$steps" --out "$out/$name" >/dev/null 2>"$out/$name.log" ||
    { echo "$name: vimd failed" >&2; cat "$out/$name.log" >&2; rm -f "$config"; exit 1; }
  "$vimd" energy "$config" --json >"$out/$name/energy.json"
  rm -f "$config"
  for f in traj.trr energy.csv confout.gro energy.json; do
    [ -f "$out/$name/$f" ] && echo "$name/$f $(sha256sum <"$out/$name/$f" | cut -c1-16)"
  done
done

#!/usr/bin/env bash
# One start state for every integrator: frame 0 of traj.trr (positions, velocities,
# forces, box) is byte-identical whichever integrator runs, on the 8-water cluster read from a
# 3-decimal .gro and on water216. Usage: start_state.sh VIMD_BINARY SOURCE_DIR WORK_DIR
set -uo pipefail
vimd=$1 src=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
failures=0
for case in "$src/tests/data/start/cluster8_3dec.toml" "$src/inputs/water216/run.toml"; do
  name=$(basename "$(dirname "$case")")_$(basename "$case" .toml)
  dir=$(dirname "$case")
  for type in rattle shake vi rk verlet; do
    toml="$work/$name.$type.toml"
    sed -e "s|^structure = \"|structure = \"$dir/|" -e "s|^topology = \"|topology = \"$dir/|" \
        -e "s/^type = .*/type = \"$type\"/" -e "s/^trajectory_every = .*/trajectory_every = 1/" "$case" > "$toml"
    out="$work/$name/$type"
    mkdir -p "$work/$name"
    "$vimd" run "$toml" --steps 1 --out "$out" > "$out.log" 2>&1
    rc=$?
    if [[ $type == verlet ]]; then
      # Velocity Verlet cannot keep constraints: refused before any frame is written.
      if [[ $rc -eq 0 ]] || ! grep -q 'use type = "rattle"' "$out.log"; then
        echo "FAIL $name verlet: expected a refusal (exit $rc)"; cat "$out.log"; failures=$((failures + 1))
      else
        echo "ok   $name verlet: refused (constrained system)"
      fi
      continue
    fi
    [[ $rc -eq 0 ]] || { echo "FAIL $name $type: exit $rc"; cat "$out.log"; failures=$((failures + 1)); continue; }
    size=$(stat -c %s "$out/traj.trr")
    head -c $((size / 2)) "$out/traj.trr" > "$out/frame0"  # two frames of equal size: steps 0 and 1
    if [[ $type == rattle ]]; then
      echo "ok   $name rattle: frame 0 is $((size / 2)) bytes"
    elif cmp -s "$work/$name/rattle/frame0" "$out/frame0"; then
      echo "ok   $name $type: frame 0 identical to rattle's"
    else
      echo "FAIL $name $type: frame 0 differs from rattle's"; cmp "$work/$name/rattle/frame0" "$out/frame0"
      failures=$((failures + 1))
    fi
  done
  # The start really was off the constraints (else the test would prove nothing).
  moved=$("$vimd" check "$work/$name.rattle.toml" | sed -n 's/.*moves positions by up to \([^ ]*\) nm.*/\1/p')
  if /usr/bin/python3 -c "import sys; sys.exit(not float('$moved') > 1e-5)" 2>/dev/null; then
    echo "ok   $name: the start is moved by up to $moved nm onto the constraints"
  else
    echo "FAIL $name: vimd check should report the start moved by > 1e-5 nm, got '$moved'"; failures=$((failures + 1))
  fi
done
exit $((failures > 0))

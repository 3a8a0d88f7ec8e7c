#!/usr/bin/env bash
# A real SIGTERM to a running `vimd run`, then `--continue`: exit 143 with the command
# that continues it, partial outputs and state.cpt kept; the continued run's outputs equal an
# uninterrupted run's byte for byte (summary.json: all but wall-time fields and the segments). Also:
# a checkpoint of another configuration or topology is refused naming what differs, a damaged one
# naming the checksum, a continue under another SIMD target unless allowed (then summary.json says
# so); a second run into a running one's directory is refused naming it, no lock outlives kill -9;
# a finished run is neither continued nor overwritten without --overwrite.
# Usage: stop_continue.sh VIMD_BINARY SOURCE_DIR WORK_DIR
set -uo pipefail
vimd=$1 src=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
failures=0
fail() { echo "FAIL $*"; failures=$((failures + 1)); }
ok() { echo "ok   $*"; }

# The 8-water cluster, long enough (~3 s) to be caught running.
sed -e "s|^structure = .*|structure = \"$src/inputs/cluster8/conf.gro\"|" \
    -e "s|^topology = .*|topology = \"$src/inputs/cluster8/topol.top\"|" \
    -e "s/^steps = .*/steps = 40000/" -e "s/^energy_every = .*/energy_every = 10/" \
    -e "s/^trajectory_every = .*/trajectory_every = 500/" "$src/inputs/cluster8/run.toml" > "$work/run.toml"

# Waits (up to 60 s) until the run writing into $1 is well under way.
wait_under_way() {
  for _ in $(seq 600); do
    [[ -f "$1/energy.csv.partial" && $(wc -l < "$1/energy.csv.partial") -gt 200 ]] && break
    sleep 0.1
  done
}

# The uninterrupted run; while it runs, a second run into its directory is refused, naming it.
"$vimd" run "$work/run.toml" --out "$work/whole" > "$work/whole.log" 2>&1 &
whole_pid=$!
wait_under_way "$work/whole"
out=$("$vimd" run "$work/run.toml" --out "$work/whole" --overwrite 2>&1); rc=$?
if [[ $rc -eq 2 && "$out" == *"another vimd run is writing into this directory (pid $whole_pid on host "*", started "* ]]; then
  ok "a second run into a running one's directory refused: ${out:0:200}"
else
  fail "a second run into a running one's directory: exit $rc: $out"
fi
wait $whole_pid || fail "uninterrupted run: $(cat "$work/whole.log")"
[[ -e "$work/whole/.vimd.lock" ]] && fail "the finished run left its lock file"

# A run killed with SIGKILL holds no lock afterwards.
"$vimd" run "$work/run.toml" --out "$work/killed" > /dev/null 2>&1 &
killed_pid=$!
wait_under_way "$work/killed"
kill -KILL $killed_pid
wait $killed_pid 2> /dev/null
out=$("$vimd" run "$work/run.toml" --out "$work/killed" --steps 10 2>&1) && ok "no lock outlives kill -9" ||
  fail "a run into the directory of a killed one: $out"

"$vimd" run "$work/run.toml" --out "$work/split" > "$work/split.log" 2> "$work/split.err" &
pid=$!
wait_under_way "$work/split"
kill -TERM $pid
wait $pid
rc=$?
if [[ $rc -ne 143 ]]; then
  fail "SIGTERM: exit $rc (wanted 143): $(cat "$work/split.err")"
elif [[ -f "$work/split/summary.json" ]]; then
  fail "SIGTERM came too late: the run had finished"
else
  ok "SIGTERM: exit 143, $(grep -o 'stopped by SIGTERM at step [0-9]*' "$work/split.err")"
fi
for f in state.cpt energy.csv.partial energy.xvg.partial traj.trr.partial; do
  [[ -f "$work/split/$f" ]] || fail "the stopped run did not keep $f"
done
[[ -f "$work/split/energy.csv" ]] && fail "the stopped run passed its partial energies off as complete"
continue_command=$(sed -n 's/^vimd: continue with: //p' "$work/split.err")
[[ -n "$continue_command" ]] || fail "no continue command printed: $(cat "$work/split.err")"

# Another configuration must not continue this run.
sed -e "s/^dt = .*/dt = 0.0005/" "$work/run.toml" > "$work/other.toml"
out=$("$vimd" run "$work/other.toml" --continue "$work/split" 2>&1); rc=$?
if [[ $rc -eq 2 && "$out" == *"dt: 0.001 in the checkpoint, 0.0005 here"* ]]; then
  ok "another config refused: ${out:0:160}..."
else
  fail "continuing with another dt: exit $rc: $out"
fi
# Nor under another switch (these keys were once left out of the identity).
for setting in "switch_smoothness = 3" "coulomb_switch = 0.5" "coulomb_modifier = \"potential-switch\"\\ncoulomb_switch = 1.2"; do
  key=${setting%% =*}
  sed -e "s/^\[forcefield\]/[forcefield]\n$setting/" "$work/run.toml" > "$work/other.toml"
  out=$("$vimd" run "$work/other.toml" --continue "$work/split" 2>&1); rc=$?
  if [[ $rc -eq 2 && "$out" == *"[forcefield] $key: "*" in the checkpoint, "* ]]; then
    ok "continuing with another $key refused"
  else
    fail "continuing with $setting: exit $rc: $out"
  fi
done
# Nor a topology that resolves to other exclusions (the n-decane melt stopped, continued with nrexcl
# 1 instead of 3): named as such.
cp -r "$src/inputs/alkane" "$work/alkane"
sed -i -e "s/^steps = .*/steps = 100000/" -e "s/^energy_every = .*/energy_every = 1/" "$work/alkane/run.toml"
"$vimd" run "$work/alkane/run.toml" --out "$work/alkane/out" > /dev/null 2>&1 &
alkane_pid=$!
for _ in $(seq 600); do
  [[ -f "$work/alkane/out/energy.csv.partial" && $(wc -l < "$work/alkane/out/energy.csv.partial") -gt 3 ]] && break
  sleep 0.1
done
kill -TERM $alkane_pid
wait $alkane_pid
sed -i 's/^DEC 3$/DEC 1/' "$work/alkane/decane.itp"
out=$("$vimd" run "$work/alkane/run.toml" --continue "$work/alkane/out" 2>&1); rc=$?
if [[ $rc -eq 2 && "$out" == *"system: exclusions: "*" in the checkpoint, "*" here"* && "$out" != *"system: bonds"* ]]; then
  ok "a topology with another nrexcl refused: ${out:0:240}..."
else
  fail "continuing with nrexcl 1 instead of 3: exit $rc: $out"
fi
# A copy of the stopped run with one bit flipped in its checkpoint: refused naming the checksum.
cp -r "$work/split" "$work/flipped"
size=$(stat -c %s "$work/flipped/state.cpt")
/usr/bin/python3 -c "import sys; f=open(sys.argv[1],'r+b'); f.seek(int(sys.argv[2])); b=f.read(1); f.seek(-1,1); f.write(bytes([b[0]^4]))" \
  "$work/flipped/state.cpt" $((size / 2))
out=$("$vimd" run "$work/run.toml" --continue "$work/flipped" 2>&1); rc=$?
[[ $rc -eq 2 && "$out" == *"flipped/state.cpt"*"checksum does not match"* ]] && ok "a flipped bit refused: $out" ||
  fail "continuing from a damaged checkpoint: exit $rc: $out"
# A copy continued under another SIMD target: refused unless allowed, and then recorded.
targets=$("$vimd" check "$work/run.toml" | sed -n 's/.*chosen at run time from \([^;]*\);.*/\1/p')
ran=$(grep -o 'SIMD [A-Za-z0-9_]*' "$work/split.log" | head -1 | cut -d' ' -f2)
other=$(tr ',' '\n' <<< "$targets" | tr -d ' ' | grep -v -x "$ran" | head -1)
if [[ -z "$other" ]]; then
  fail "no second SIMD target on this machine to continue under (targets: $targets)"
else
  cp -r "$work/split" "$work/simd"
  out=$("$vimd" --simd "$other" run "$work/run.toml" --continue "$work/simd" 2>&1); rc=$?
  [[ $rc -eq 2 && "$out" == *"SIMD target $ran then, $other now"*"--simd $ran"*"--allow-platform-change"* ]] &&
    ok "a continue under $other refused" || fail "continuing under $other after $ran: exit $rc: $out"
  "$vimd" --simd "$other" run "$work/run.toml" --continue "$work/simd" --allow-platform-change > "$work/simd.log" 2>&1 ||
    fail "continuing with --allow-platform-change: $(cat "$work/simd.log")"
  if grep -q "\"first_step\": 0, \"simd_target\": \"$ran\"" "$work/simd/summary.json" &&
     grep -q "\"simd_target\": \"$other\".*\"platform_change\": \"allowed by --allow-platform-change: SIMD target $ran then, $other now\"" \
       "$work/simd/summary.json"; then
    ok "summary.json records both segments' SIMD targets and the allowed change"
  else
    fail "summary.json after a SIMD change: $(cat "$work/simd/summary.json")"
  fi
fi
# Another thread count sums in another order: refused too, naming the count to continue with.
ran_threads=$(grep -o '[0-9]* threads\?' "$work/split.log" | head -1 | cut -d' ' -f1)
other_threads=$((ran_threads == 1 ? 2 : 1))
out=$("$vimd" --threads $other_threads run "$work/run.toml" --continue "$work/split" 2>&1); rc=$?
[[ $rc -eq 2 && "$out" == *"threads $ran_threads then, $other_threads now"*"--threads $ran_threads"* ]] &&
  ok "a continue with another thread count refused" ||
  fail "continuing with $other_threads threads after $ran_threads: exit $rc: $out"
# A continue to a step the run has already passed: refused at the line that sets the steps.
steps_line=$(grep -n '^steps' "$work/run.toml" | cut -d: -f1)
sed 's/^steps = .*/steps = 1/' "$work/run.toml" > "$work/few_steps.toml"
out=$("$vimd" run "$work/few_steps.toml" --continue "$work/split" 2>&1); rc=$?
[[ $rc -eq 2 && "$out" == *"few_steps.toml:$steps_line:"*"not before the configured 1 steps"* ]] &&
  ok "a continue to fewer steps refused at the steps line" || fail "continuing to fewer steps: exit $rc: $out"
out=$("$vimd" run "$work/run.toml" --continue "$work/split" --steps 1 2>&1); rc=$?
[[ $rc -eq 2 && "$out" == *"--steps"*"not before the configured 1 steps"* ]] &&
  ok "--steps below the stop refused naming --steps" || fail "continuing with --steps 1: exit $rc: $out"
# Nor may a new run silently replace the stopped one.
out=$("$vimd" run "$work/run.toml" --out "$work/split" 2>&1); rc=$?
[[ $rc -eq 2 && "$out" == *"holds a stopped run"* ]] && ok "a stopped run is not overwritten" || fail "new run over a stopped one: exit $rc: $out"

${continue_command/#vimd /$vimd } > "$work/continue.log" 2>&1 || fail "continuing: $(cat "$work/continue.log")"
for f in energy.csv energy.xvg traj.trr confout.gro; do
  if cmp -s "$work/whole/$f" "$work/split/$f"; then ok "$f identical to the uninterrupted run's"; else fail "$f differs"; fi
done
if diff <(grep -v -e _seconds -e ns_per_day -e '"first_step"' "$work/whole/summary.json") \
        <(grep -v -e _seconds -e ns_per_day -e '"first_step"' "$work/split/summary.json") > /dev/null; then
  ok "summary.json identical but for wall time and segments"
else
  fail "summary.json differs"; diff "$work/whole/summary.json" "$work/split/summary.json"
fi
[[ $(grep -c '"first_step"' "$work/split/summary.json") -eq 2 ]] || fail "summary.json does not list two segments"
ls "$work/split"/*.partial > /dev/null 2>&1 && fail "partial files left after the continued run finished"

out=$("$vimd" run "$work/run.toml" --continue "$work/split" 2>&1); rc=$?
[[ $rc -eq 2 && "$out" == *"nothing to continue"* ]] && ok "a finished run is not continued" || fail "continuing a finished run: exit $rc: $out"
out=$("$vimd" run "$work/run.toml" --out "$work/split" --steps 10 2>&1); rc=$?
[[ $rc -eq 2 && "$out" == *"already holds a finished run"* ]] && ok "a finished run is not overwritten" || fail "overwriting: exit $rc: $out"
"$vimd" run "$work/run.toml" --out "$work/split" --steps 10 --overwrite > /dev/null 2>&1 && ok "--overwrite replaces it" || fail "--overwrite"

echo "$failures failed"
[[ $failures -eq 0 ]]

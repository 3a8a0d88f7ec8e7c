#!/usr/bin/env bash
# Bad input must give a clear error naming file and line, a non-zero exit, and no output
# posing as a result. Usage: cli_errors.sh VIMD_BINARY SOURCE_DIR WORK_DIR
set -uo pipefail
vimd=$1 src=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
failures=0
expect_error() {  # name, expected exit code, expected text, command...
  local name=$1 code=$2 text=$3; shift 3
  local out rc
  "$@" > "$work/stdout" 2> "$work/stderr"; rc=$?
  out=$(cat "$work/stdout" "$work/stderr")
  if [[ $rc -ne $code || "$out" != *"$text"* ]]; then
    echo "FAIL $name: exit $rc (wanted $code), output: $out"; failures=$((failures + 1))
  elif [[ $(tail -c 1 "$work/stderr" | od -An -c | tr -d ' ') != '\n' ]]; then
    # The message must end its line, or the shell prompt (or the next message) runs on.
    echo "FAIL $name: the error message does not end with a newline: $out"; failures=$((failures + 1))
  else
    echo "ok   $name: $out" | head -1
  fi
}
water="$src/inputs/water216"
cat > "$work/typo.toml" <<TOML
[system]
structure = "$water/conf.gro"
topology = "$water/topol.top"
[integrator]
type = "rattle"
stpes = 10
TOML
expect_error "unknown key" 2 "typo.toml:6" "$vimd" check "$work/typo.toml"
expect_error "suggestion" 2 "steps" "$vimd" check "$work/typo.toml"

head -c 2000 "$water/conf.gro" > "$work/truncated.gro"
sed -e "s|$water/conf.gro|$work/truncated.gro|" -e "s/stpes/steps/" "$work/typo.toml" > "$work/truncated.toml"
expect_error "truncated gro" 2 "truncated.gro" "$vimd" run "$work/truncated.toml" --out "$work/out"
[[ ! -e "$work/out/confout.gro" ]] || { echo "FAIL truncated gro left a confout.gro"; failures=$((failures + 1)); }

sed -e "s/stpes = 10/steps = 10\ndt = 0.5/" "$work/typo.toml" > "$work/blowup.toml"
printf '[forcefield]\nneighbor_skin = 0.03\n[output]\ndir = "%s"\n' "$work/blowup" >> "$work/blowup.toml"
expect_error "divergent run" 3 "did not converge" "$vimd" run "$work/blowup.toml"
[[ ! -e "$work/blowup/confout.gro" && ! -e "$work/blowup/energy.csv" ]] || {
  echo "FAIL a failed run left complete-looking output"; failures=$((failures + 1)); }

# energy and check need no velocities (GROMACS's spc216.gro and gmx solvate output have none); run does.
awk 'NR <= 2 { print; next } NF >= 9 { printf "%s\n", substr($0, 1, 44); next } { print }' "$water/conf.gro" \
  > "$work/novel.gro"
sed -e "s|$water/conf.gro|$work/novel.gro|" -e "s/stpes/steps/" "$work/typo.toml" > "$work/novel.toml"
printf '[forcefield]\nneighbor_skin = 0.03\n' >> "$work/novel.toml"  # the 1.86 nm box allows no more
for command in check energy; do
  if "$vimd" $command "$work/novel.toml" > "$work/novel.$command" 2>&1; then
    echo "ok   $command without velocities"
  else
    echo "FAIL $command without velocities: $(cat "$work/novel.$command")"; failures=$((failures + 1))
  fi
done
expect_error "run without velocities" 2 "has no velocities: set [integrator] temperature" \
  "$vimd" run "$work/novel.toml" --out "$work/novel"

# A disk that fills up during the run (simulated with a file-size limit): a clear error, exit 1.
sed -e "s/stpes = 10/steps = 2000/" "$work/typo.toml" > "$work/full.toml"
printf '[forcefield]\nneighbor_skin = 0.03\n[output]\nenergy_every = 1\n' >> "$work/full.toml"
expect_error "disk full during the run" 1 ".partial: cannot write (disk full?): File too large" \
  bash -c "ulimit -f 40; exec \"\$0\" run \"\$1\" --out \"\$2\"" "$vimd" "$work/full.toml" "$work/full"

# A run that blows up (20 fs on flexible water) stops at once, naming the atom, keeping the last
# good frame; no NaN reaches a file.
case_dir="$src/tests/bad_inputs/run_blows_up"
expect_error "blow-up" 3 "blew up at step 1: 1 atom(s)" "$vimd" run "$case_dir/run.toml" --out "$work/blowup20"
[[ -f "$work/blowup20/last_good.gro" ]] || { echo "FAIL blow-up: no last_good.gro"; failures=$((failures + 1)); }
if grep -qil -e nan -e inf "$work/blowup20"/energy.*.partial; then
  echo "FAIL blow-up: NaN or Inf in the energy files"; failures=$((failures + 1))
fi

expect_error "bad --pin" 105 "--pin: sometimes not in {auto,on,off}" "$vimd" --pin sometimes check "$case_dir/run.toml"

# An output path too long for the system (4085 characters, in components of 200): the system's
# reason, not a failed cleanup of a file never created.
long_out=$work
while (( ${#long_out} < 3880 )); do long_out+=/$(printf '%0200d' 0); done
long_out+=/$(printf '%0*d' $((4085 - ${#long_out} - 1)) 0)
expect_error "output path too long" 2 "cannot write in the output directory: File name too long" \
  "$vimd" run "$case_dir/run.toml" --out "$long_out"

# The flag only means something for a continue; alone it would be silently ignored.
expect_error "--allow-platform-change without --continue" 107 "--allow-platform-change requires --continue" \
  "$vimd" run "$case_dir/run.toml" --allow-platform-change --out "$work/allow"

echo "$((13 - failures)) passed, $failures failed"
[[ $failures -eq 0 ]]

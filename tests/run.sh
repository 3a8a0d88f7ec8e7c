#!/usr/bin/env bash
# The test command: installs dependencies, builds, and runs every test (unit tests and the
# end-to-end script checks) through ctest; then builds the fast unit tests and the fuzz-corpus
# replay with AddressSanitizer + UndefinedBehaviorSanitizer (build-sanitize/) and runs them there.
# Ends with the wall time of each phase (the fresh-clone run should stay under 15 minutes on 2 cores).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
phases=()
started=$SECONDS
phase_done() { phases+=("$(printf '%-44s %5d s' "$1" $((SECONDS - started)))"); started=$SECONDS; }

bash "$root/app/setup.sh" all
phase_done "dependencies and build (build/)"
cmake -S "$root" -B "$root/build-sanitize" -DCMAKE_BUILD_TYPE=Release -DVIMD_SANITIZE=ON >/dev/null
cmake --build "$root/build-sanitize" -j"$(nproc)" --target sanitize_tests
phase_done "sanitizer build (build-sanitize/)"

# Tests run side by side, one per core. Each may use two OpenMP threads, so threads that wait sleep
# instead of spinning (spinning threads of one test would starve the other's).
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE}
# Nor are they pinned: vimd's --pin auto would put every test's threads on the same CPUs.
export OMP_PROC_BIND=${OMP_PROC_BIND:-false}
jobs=$(nproc)
status=0
(cd "$root/build" && OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} ctest -j"$jobs" --output-on-failure --timeout 900 "$@") || status=$?
phase_done "tests (build/)"
echo "== unit tests and fuzz-corpus replay under ASan + UBSan (build-sanitize) =="
# Any finding fails its test: UBSan halts (the build also has -fno-sanitize-recover), ASan always does.
(cd "$root/build-sanitize" &&
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1} \
  UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1} \
  OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} ctest -j"$jobs" --output-on-failure --timeout 900 -L sanitize "$@") || status=$?
phase_done "tests under the sanitizers (build-sanitize/)"
echo "== wall time per phase =="
printf '%s\n' "${phases[@]}"
exit $status

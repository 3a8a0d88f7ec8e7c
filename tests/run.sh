#!/usr/bin/env bash
# The test command: installs dependencies, builds, and runs every test (unit tests and the
# end-to-end script checks) through ctest; then builds the fast unit tests and the fuzz-corpus
# replay with AddressSanitizer + UndefinedBehaviorSanitizer (build-sanitize/) and runs them there.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$root/app/setup.sh" all
cmake -S "$root" -B "$root/build-sanitize" -DCMAKE_BUILD_TYPE=Release -DVIMD_SANITIZE=ON >/dev/null
cmake --build "$root/build-sanitize" -j"$(nproc)" --target sanitize_tests

status=0
(cd "$root/build" && OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} ctest --output-on-failure --timeout 900 "$@") || status=$?
echo "== unit tests and fuzz-corpus replay under ASan + UBSan (build-sanitize) =="
# Any finding fails its test: UBSan halts (the build also has -fno-sanitize-recover), ASan always does.
(cd "$root/build-sanitize" &&
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1} \
  UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1} \
  OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} ctest --output-on-failure --timeout 900 -L sanitize "$@") || status=$?
exit $status

#!/usr/bin/env bash
# The test command: installs dependencies, builds, and runs every test (unit tests and the
# end-to-end script checks) through ctest.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$root/app/setup.sh"
cd "$root/build"
OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} ctest --output-on-failure --timeout 900 "$@"

#!/usr/bin/env bash
# Reruns the validation study (issue 4) and rewrites its report.
#
#   validation/run_all.sh                       # full study (~1 h): validation/report/README.md + PNGs
#   validation/run_all.sh --quick [--out DIR]   # smoke test (< 5 min): build/report-quick/ or DIR
#
# Other options (see `validation/run_all.sh --help`): --vimd PATH, --threads N, --runs DIR, --reuse.
# Builds build/vimd first unless $VIMD or --vimd names another binary.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

if [[ -z ${VIMD:-} && " $* " != *" --vimd "* && -f $root/build/CMakeCache.txt ]]; then
  cmake --build "$root/build" -j2 --target vimd >/dev/null
fi
PYTHONPATH="$root/validation${PYTHONPATH:+:$PYTHONPATH}" exec /usr/bin/python3 -m study "$@"

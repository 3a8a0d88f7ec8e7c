#!/usr/bin/env bash
# Installs what vimd needs from Debian's packages (only what is missing) and builds in build/ the
# targets named (default: the vimd program; "all" for everything, tests included).
# Idempotent: a second run installs nothing and rebuilds only what changed.
# With --fuzz it also installs clang and libFuzzer and builds the readers' fuzz targets in
# build-fuzz/ (fuzz_gro, fuzz_top, fuzz_toml; see docs/user-guide.md).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
fuzz=0
targets=()
for arg in "$@"; do
  if [[ $arg == --fuzz ]]; then fuzz=1; else targets+=("$arg"); fi
done
((${#targets[@]})) || targets=(vimd)

packages=(g++ cmake make pkg-config libeigen3-dev libgtest-dev libtomlplusplus-dev libcli11-dev libhwy-dev
          libfftw3-dev gromacs time python3-numpy python3-scipy python3-matplotlib python3-mdanalysis
          python3-dev pybind11-dev python3-pytest)
((fuzz)) && packages+=(clang libclang-rt-14-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$root/build" -j"$(nproc)" --target "${targets[@]}"
if ((fuzz)); then
  # clang is another compiler, so another tree.
  CXX=clang++ cmake -S "$root" -B "$root/build-fuzz" -DCMAKE_BUILD_TYPE=Release -DVIMD_FUZZ=ON >/dev/null
  cmake --build "$root/build-fuzz" -j"$(nproc)"
fi

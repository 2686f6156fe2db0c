#!/usr/bin/env bash
# Configures and builds one build folder; warnings are errors, ccache and Ninja, jobs = cores.
# Usage: scripts/build.sh DIR [extra cmake args...] [-- TARGET...]   (no targets: all)
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
dir="$1"; shift
cmake_args=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do cmake_args+=("$1"); shift; done
[ $# -gt 0 ] && shift  # the "--"
targets=("$@")
# ccache: paths relative to the checkout, so every clone (CI's included) shares the cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$top}"
export CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-true}"
cmake -S "$top" -B "$dir" -G Ninja -DLIDARFUSE_WERROR=ON "${cmake_args[@]}" >"$dir.configure.log" 2>&1 ||
    { cat "$dir.configure.log"; exit 1; }
if [ ${#targets[@]} -gt 0 ]; then
    cmake --build "$dir" -j "$(nproc)" --target "${targets[@]}"
else
    cmake --build "$dir" -j "$(nproc)"
fi

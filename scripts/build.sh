#!/usr/bin/env bash
# Configures and builds one build folder. Usage: scripts/build.sh DIR [extra cmake args...]
# Warnings are errors. Uses ccache and Ninja; jobs = number of cores.
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
dir="$1"; shift
# ccache: paths relative to the checkout, so every clone (CI's included) shares the cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$top}"
export CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-true}"
cmake -S "$top" -B "$dir" -G Ninja -DLIDARFUSE_WERROR=ON "$@" >"$dir.configure.log" 2>&1 ||
    { cat "$dir.configure.log"; exit 1; }
cmake --build "$dir" -j "$(nproc)"

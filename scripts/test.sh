#!/usr/bin/env bash
# Installs everything, builds, and runs every test twice: an optimised build with warnings
# as errors, then an AddressSanitizer + UndefinedBehaviorSanitizer build.
# The sample captures come from $LIDARFUSE_DATA_DIR (default ../shared/data beside the
# checkout); tests that need them skip with a message where the folder is absent.
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
cd "$top"
"$top/scripts/setup.sh"

data_args=()
if [ -n "${LIDARFUSE_DATA_DIR:-}" ]; then data_args=(-DLIDARFUSE_DATA_DIR="$LIDARFUSE_DATA_DIR"); fi
jobs="$(nproc)"
start=$(date +%s)
stage() { echo "== $1 (at $(( $(date +%s) - start )) s)"; }

stage "release build (RelWithDebInfo, -Werror)"
"$top/scripts/build.sh" "$top/build" -DCMAKE_BUILD_TYPE=RelWithDebInfo "${data_args[@]}"
stage "release tests"
ctest --test-dir "$top/build" -j "$jobs" --output-on-failure --timeout 600

stage "sanitizer build (ASan + UBSan, -O1, assertions on)"
"$top/scripts/build.sh" "$top/build-asan" -DCMAKE_BUILD_TYPE=Debug \
    -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" -DCMAKE_C_FLAGS_DEBUG="-O1 -g" \
    -DLIDARFUSE_SANITIZE=address,undefined -DLIDARFUSE_BUILD_BENCH=OFF "${data_args[@]}"
stage "sanitizer tests"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1 \
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir "$top/build-asan" -j "$jobs" --output-on-failure --timeout 900

echo "== all tests passed in $(( $(date +%s) - start )) s"

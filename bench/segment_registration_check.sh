#!/usr/bin/env bash
# The segment registration (issue 20, core/initial/station_registration.hpp) on every road
# scene, seed and station spacing, offline: `lidarfuse sim --stations 2
# --sensors-per-station 4`, each station fused in its road frame (`fuse --world road
# --save-cloud 15`), then segment_registration_bench places station1 against station0
# from nothing and prints its error against the truth (`name value unit` lines).
#   bench/segment_registration_check.sh BUILD_DIR WORK_DIR [FIRST_SEED=1] [LAST_SEED=3]
#       [SPACINGS="60 80 100 120"]
# The captures and fused clouds stay in WORK_DIR and are reused by the next run.
set -euo pipefail
build="$(cd "$1" && pwd)"; work="$2"; first="${3:-1}"; last="${4:-3}"
spacings="${5:-60 80 100 120}"
tool="$build/tools/lidarfuse"
source "$(dirname "$0")/segment_cases.sh"
segment_cases "$tool" "$work" "$first" "$last" "$spacings" 1 15 15
"$build/bench/segment_registration_bench" 2 15 "${cases[@]}"

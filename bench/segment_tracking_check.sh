#!/usr/bin/env bash
# The segment's continuous registration (issue 20) offline, on every road scene and seed:
# `lidarfuse sim --stations 2 --sensors-per-station 4`, each station fused in its road
# frame with its cloud of every frame saved (`fuse --world road --save-cloud`), then
# `segment_registration_bench track` runs a segment FusionEngine on those clouds, once per
# segment config given, and prints station1's strict RMSE (its frame, and each of its
# sensors in the segment's root frame) against the truth, plus how far each station's own
# sensors disagree about its frame (`name value unit` lines).
#   bench/segment_tracking_check.sh BUILD_DIR WORK_DIR FIRST_SEED LAST_SEED SPACINGS CONFIG...
# A CONFIG is a segment station.yaml (its registration section is what is read). The
# captures and clouds (about 0.6 GB per case) stay in WORK_DIR for the next run.
set -euo pipefail
build="$(cd "$1" && pwd)"; work="$2"; first="$3"; last="$4"; spacings="$5"; shift 5
tool="$build/tools/lidarfuse"
source "$(dirname "$0")/segment_cases.sh"
segment_cases "$tool" "$work" "$first" "$last" "$spacings" 4 5 79
for c in "${cases[@]}"; do
    for config in "$@"; do
        echo "segment_config $(basename "$config" .yaml) name"
        "$build/bench/segment_registration_bench" track "$config" 5 79 "$c" | grep -v "_lidar[0-9]_"
    done
done

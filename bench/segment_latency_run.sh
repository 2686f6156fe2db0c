#!/usr/bin/env bash
# A segment daemon's latency, CPU and bandwidth with 2, 3 and 4 stations (issue 20):
# `lidarfuse sim --stations 4 --sensors-per-station 4` on the straight road (60 m apart by
# default: four stations fit on its 320 m), each station fused in its road frame with the
# clouds of 1 s saved (`fuse --world road --save-cloud`), then segment_latency_bench plays
# the first K stations' clouds at 20 Hz into a segment lidarfused for each K, with the full
# clouds and thinned to THIN_M voxels (a station's points_voxel topic). Prints `name value
# unit` lines, one block per run.
#   bench/segment_latency_run.sh BUILD_DIR WORK_DIR [SECONDS=20] [THIN_M=0.5] [SPACING_M=60]
# The capture and clouds (about 0.7 GB) stay in WORK_DIR for the next run.
set -euo pipefail
build="$(cd "$1" && pwd)"; work="$2"; seconds="${3:-20}"; thin="${4:-0.5}"; spacing="${5:-60}"
tool="$build/tools/lidarfuse"
source "$(dirname "$0")/segment_cases.sh"
c="$work/straight-4x4-$spacing"
if [ ! -f "$c/F3/fused_29.ply" ]; then
    "$tool" sim --scenario straight --seed 1 --stations 4 --sensors-per-station 4 \
        --station-spacing-m "$spacing" --seconds 2 --quiet --out "$c/S" >/dev/null
    fuse_stations "$tool" "$c" 4 10 29
fi
for stations in 2 3 4; do
    echo "segment_run ${stations}stations_full name"
    "$build/bench/segment_latency_bench" "$c" "$stations" "$seconds"
    echo "segment_run ${stations}stations_thin$thin name"
    "$build/bench/segment_latency_bench" "$c" "$stations" "$seconds" --thin "$thin"
done

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
mkdir -p "$work"
cases=()
for scene in straight curve; do
    for seed in $(seq "$first" "$last"); do
        for spacing in $spacings; do
            c="$work/$scene-$seed-$spacing"
            if [ ! -f "$c/F1/fused_15.ply" ]; then
                "$tool" sim --scenario "$scene" --seed "$seed" --stations 2 --sensors-per-station 4 \
                    --station-spacing-m "$spacing" --seconds 1 --quiet --out "$c/S" >/dev/null
                for j in 0 1; do
                    "$tool" fuse "$c/S/station$j/capture.pcap" --config "$c/S/station$j/station.yaml" \
                        --out "$c/F$j" --world road --save-cloud 15 --quiet >/dev/null
                done
            fi
            cases+=("$c")
        done
    done
done
"$build/bench/segment_registration_bench" 2 15 "${cases[@]}"

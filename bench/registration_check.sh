#!/usr/bin/env bash
# The initial registration on every real rig and on simulated 4-sensor stations, in one run:
# the check a change to registration is held to (the real sets and the simulator together).
#   bench/registration_check.sh BUILD_DIR WORK_DIR [FIRST_SEED=1] [LAST_SEED=15]
# Simulates WORK_DIR/S_N and WORK_DIR/S_N_still (S curve, straight, intersection, with and
# without the poles' motion, 0.3 s each; kept for the next run), then runs
# registration_diagnose_bench over $LIDARFUSE_DATA_DIR/real/* (default ../shared/data) and
# them. Prints one line per capture and the bench's `diagnose_* value unit` totals; a
# wrong sensor in a simulated capture says "wrong 1" or more on its line (the real rigs
# count theirs as wrong by the bench's tight tolerance: compare their errors instead).
set -euo pipefail
build="$1"; work="$2"; first="${3:-1}"; last="${4:-15}"
top="$(cd "$(dirname "$0")/.." && pwd)"
data="${LIDARFUSE_DATA_DIR:-$top/../shared/data}"
mkdir -p "$work"
captures=()
for scenario in curve straight intersection; do
    for seed in $(seq "$first" "$last"); do
        for motion in "" "_still"; do
            dir="$work/${scenario}_${seed}${motion}"
            if [ ! -f "$dir/capture.pcap" ]; then
                flag=(); [ -n "$motion" ] && flag=(--no-motion)
                "$build/tools/lidarfuse" sim --scenario "$scenario" --seed "$seed" --seconds 0.3 \
                    "${flag[@]}" --out "$dir" >/dev/null
            fi
            captures+=("$dir")
        done
    done
done
rigs=()
for rig in "$data"/real/*/; do [ -d "$rig" ] && rigs+=("${rig%/}"); done
[ ${#rigs[@]} -gt 0 ] || echo "registration_check: no real rigs under $data/real (simulated only)" >&2
"$build/bench/registration_diagnose_bench" "${rigs[@]}" "${captures[@]}" quiet=1 threads=2 \
    truth_shift_s=0.025 2>&1 | grep -E '^(/|diagnose_)' | sed -E 's/ time [0-9.]+ s \([^)]*\)//'

# Sourced by bench/segment_registration_check.sh and bench/segment_tracking_check.sh: the
# cases of a road segment of two stations (issue 20) on every road scene, seed and spacing.
# segment_cases TOOL WORK FIRST_SEED LAST_SEED "SPACINGS" SECONDS FIRST_FRAME LAST_FRAME
# makes WORK/<scene>-<seed>-<spacing>/ for scenes straight and curve: S/ from `lidarfuse sim
# --stations 2 --sensors-per-station 4`, F0/ and F1/ from `lidarfuse fuse` of each station
# in its road frame with its clouds of FIRST_FRAME..LAST_FRAME saved; a case whose last
# cloud is there is reused. The folders are left in the array `cases`.
segment_cases() {
    local tool="$1" work="$2" first="$3" last="$4" spacings="$5" seconds="$6" from="$7" to="$8"
    local scene seed spacing c j k save
    cases=()
    mkdir -p "$work"
    for scene in straight curve; do
        for seed in $(seq "$first" "$last"); do
            for spacing in $spacings; do
                c="$work/$scene-$seed-$spacing"
                cases+=("$c")
                [ -f "$c/F1/fused_$to.ply" ] && continue
                "$tool" sim --scenario "$scene" --seed "$seed" --stations 2 \
                    --sensors-per-station 4 --station-spacing-m "$spacing" --seconds "$seconds" \
                    --quiet --out "$c/S" >/dev/null
                save=()
                for k in $(seq "$from" "$to"); do save+=(--save-cloud "$k"); done
                for j in 0 1; do
                    "$tool" fuse "$c/S/station$j/capture.pcap" --config "$c/S/station$j/station.yaml" \
                        --out "$c/F$j" --world road "${save[@]}" --quiet >/dev/null
                done
            done
        done
    done
}

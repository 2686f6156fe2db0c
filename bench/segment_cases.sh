# Sourced by the segment benches (issue 20): a simulated segment's stations fused with their
# clouds saved, and the cases of two stations on every road scene, seed and spacing.

# fuse_stations TOOL CASE STATIONS FIRST_FRAME LAST_FRAME: CASE/F<j>/ from `lidarfuse fuse`
# of CASE/S/station<j> (j < STATIONS) in its road frame, its clouds of FIRST..LAST saved.
fuse_stations() {
    local tool="$1" c="$2" stations="$3" from="$4" to="$5" j k save=()
    for k in $(seq "$from" "$to"); do save+=(--save-cloud "$k"); done
    for j in $(seq 0 $((stations - 1))); do
        "$tool" fuse "$c/S/station$j/capture.pcap" --config "$c/S/station$j/station.yaml" \
            --out "$c/F$j" --world road "${save[@]}" --quiet >/dev/null
    done
}

# segment_cases TOOL WORK FIRST_SEED LAST_SEED "SPACINGS" SECONDS FIRST_FRAME LAST_FRAME
# makes WORK/<scene>-<seed>-<spacing>/ for scenes straight and curve: S/ from `lidarfuse sim
# --stations 2 --sensors-per-station 4`, F0/ and F1/ from fuse_stations; a case whose last
# cloud is there is reused. The folders are left in the array `cases`.
segment_cases() {
    local tool="$1" work="$2" first="$3" last="$4" spacings="$5" seconds="$6" from="$7" to="$8"
    local scene seed spacing c
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
                fuse_stations "$tool" "$c" 2 "$from" "$to"
            done
        done
    done
}

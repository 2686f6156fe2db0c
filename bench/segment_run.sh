#!/usr/bin/env bash
# A road segment over DDS on one machine (issue 20): `lidarfuse sim --stations K
# --sensors-per-station N` on the straight road, one lidarfused per station (its sensors'
# captures replayed into it, its fused cloud on rt/station<j>/points), and a segment
# lidarfused whose sensors are those clouds (station.yaml `source: {dds: ...}`). The
# segment's poses of every station are compared with the simulator's truth (`lidarfuse
# eval`, station0 as the root).
#   bench/segment_run.sh BUILD_DIR [STATIONS=2] [SENSORS=4] [SECONDS=16] [RATE=0.3]
#       [SPACING_M=80] [STATION_WORLD=road]
# RATE slows the replays so that K stations' daemons and the segment's share 2 cores.
# STATION_WORLD=road (default): the stations publish in their road frames and the segment
# registers them with `registration.initial_method: stations` (core/initial/
# station_registration.hpp); a station's truth is its road frame in the simulator's world
# (segment_registration_bench truth). STATION_WORLD=sensor: in their root sensors' first
# frames, registered by the features (the mirrored pose of bench/BENCHMARK.md); a station's
# truth is then its root sensor's first pose.
# Loopback DDS (domain 77), ports 7502 + 100 j + 2 k; prints `name value unit`, and keeps
# the daemons' logs and outputs in the printed folder.
set -euo pipefail
build="$(cd "$1" && pwd)"; stations="${2:-2}"; sensors="${3:-4}"; seconds="${4:-16}"
rate="${5:-0.3}"; spacing="${6:-80}"; station_world="${7:-road}"
tool="$build/tools/lidarfuse"; daemon="$build/daemon/lidarfused"
work="$(mktemp -d /tmp/lidarfuse-segment.XXXXXX)"
domain=77
export CYCLONEDDS_URI='<General><Interfaces><NetworkInterface name="lo"/></Interfaces><MaxMessageSize>65500B</MaxMessageSize><FragmentSize>64000B</FragmentSize></General><Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>40</MaxAutoParticipantIndex></Discovery><Tracing><Verbosity>severe</Verbosity></Tracing>'
"$tool" sim --scenario straight --stations "$stations" --sensors-per-station "$sensors" \
    --station-spacing-m "$spacing" --seconds "$seconds" --quiet --out "$work/sim" >/dev/null

# The segment's config: its sensors are the stations' clouds, in the stations' fused frames,
# so that each station's tf tree (its frame_prefix) hangs below the segment's frame.
{
    echo "station: segment"; echo "root: station0"; echo "sensors:"
    for j in $(seq 0 $((stations - 1))); do
        echo "  - {name: station$j, source: {dds: {topic: rt/station$j/points, domain_id: $domain, frame_id: station$j/lidarfuse/fused}}}"
    done
    echo "world: {frame: sensor}"
    [ "$station_world" = road ] && echo "registration: {initial_method: stations}"
    echo "output: {directory: $work/segment, dds: {domain_id: $domain, namespace: segment}}"
} >"$work/segment.yaml"
pids=()
"$daemon" --config "$work/segment.yaml" >"$work/segment.log" 2>&1 &
segment_pid=$!
# Station j's config: its sensors on ports 7502 + 100 j + 2 k, its cloud on rt/station<j>.
for j in $(seq 0 $((stations - 1))); do
    {
        echo "station: station$j"; echo "root: lidar0"; echo "sensors:"
        for k in $(seq 0 $((sensors - 1))); do
            echo "  - {name: lidar$k, udp_port: $((7502 + 100 * j + 2 * k)), metadata: $work/sim/station$j/lidar$k.json}"
        done
        echo "network: {bind_address: 127.0.0.1}"
        echo "world: {frame: $station_world}"
        echo "output: {directory: $work/station$j, dds: {domain_id: $domain, namespace: station$j, frame_prefix: station$j/}}"
    } >"$work/station$j.yaml"
    "$daemon" --config "$work/station$j.yaml" >"$work/station$j.log" 2>&1 &
    pids+=($!)
done
sleep 3
replays=()
for j in $(seq 0 $((stations - 1))); do
    maps=()
    for k in $(seq 0 $((sensors - 1))); do maps+=(--port-map "$((7502 + 2 * k)):$((7502 + 100 * j + 2 * k))"); done
    "$tool" replay --quiet --rate "$rate" "${maps[@]}" "$work/sim/station$j/capture.pcap" >/dev/null &
    replays+=($!)
done
wait "${replays[@]}"
sleep 8  # the stations and the segment catch up
kill -TERM "${pids[@]}"; wait "${pids[@]}" || true
sleep 3
kill -TERM "$segment_pid"; wait "$segment_pid" || true

# The truth of station j in the segment: the frame its cloud is published in, at every
# stamp of its root. road: its road frame (fixed once) in the simulator's world. sensor: its
# root sensor (lidar0) at its first frame (a station's sensor world frame does not sway with
# its root; its first fused frame may be a few frames after the capture's first, a few mm
# of sway).
{
    echo "frame,sensor,t_ns,x,y,z,qw,qx,qy,qz"
    for j in $(seq 0 $((stations - 1))); do
        if [ "$station_world" = road ]; then
            "$build/bench/segment_registration_bench" truth "$work/sim/station$j" \
                "$work/station$j/poses.csv" "station$j" | tail -n +2
        else
            awk -F, -v name="station$j" 'NR > 1 && $2 == "lidar0" {
                if (!pose) pose = $4 "," $5 "," $6 "," $7 "," $8 "," $9 "," $10
                print $1 "," name "," $3 "," pose }' "$work/sim/station$j/ground_truth.csv"
        fi
    done
} >"$work/segment_truth.csv"
for j in $(seq 1 $((stations - 1))); do
    registered=$(awk -v name="station$j" '$0 ~ "name: " name "$" {getline; print $2}' \
        "$work/segment/extrinsics.yaml")
    echo "segment_station${j}_registered ${registered:-false} flag"
done
echo "segment_initial_registration_refusals $(grep -c "initial registration failed" "$work/segment.log" || true) attempts"
echo "segment_frames_fused $(grep -o "fused [0-9]* frames" "$work/segment.log" | awk '{print $2}') frames"
if grep -q ",station1," "$work/segment/poses.csv"; then
    "$tool" eval --gt "$work/segment_truth.csv" --poses "$work/segment/poses.csv" --root station0 |
        grep -E "station[0-9]+_(matched_frames|strict_rmse_trans|strict_rmse_rot)"
fi
echo "segment_work_dir $work path"

#!/usr/bin/env bash
# The main job on the built-in default: installs what it needs, builds the two executables it
# runs (Release, in build-release/, reused when already there), simulates a 4-LiDAR
# roadside station (curve scenario, swaying poles, traffic), replays the capture through
# lidarfused's UDP sockets on loopback at recorded speed, stops the daemon, and prints the
# accuracy of the poses it wrote against the simulator's ground truth.
#
# Options (environment): SCENARIO=curve|straight|intersection  SIM_SECONDS=10  SEED=1
#                        VOXEL=1.0  OUT=<folder, default a temporary one>
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
scenario="${SCENARIO:-curve}"
seconds="${SIM_SECONDS:-10}"
seed="${SEED:-1}"
voxel="${VOXEL:-1.0}"
out="${OUT:-$(mktemp -d /tmp/lidarfuse-demo.XXXXXX)}"

"$top/scripts/setup.sh" --demo
bin="$top/build-release"
echo "== building lidarfuse and lidarfused (Release) in $bin"
"$top/scripts/build.sh" "$bin" -DCMAKE_BUILD_TYPE=Release -DLIDARFUSE_BUILD_TESTS=OFF \
    -DLIDARFUSE_BUILD_BENCH=OFF -DLIDARFUSE_UNITY_BUILD=ON -- lidarfuse lidarfused >"$bin.build.log" 2>&1 ||
    { tail -n 40 "$bin.build.log"; exit 1; }

echo "== simulating ${scenario}: 4 OS1-64 at 1024x20, ${seconds} s, seed ${seed} -> ${out}/sim"
"$bin/tools/lidarfuse" sim --scenario "$scenario" --seconds "$seconds" --seed "$seed" --out "$out/sim" \
    | grep -E "sim_(rays|realtime)"

# The simulator's station.yaml plus the daemon's output section; loopback only.
cp "$out/sim/station.yaml" "$out/sim/daemon.yaml"
cat >>"$out/sim/daemon.yaml" <<YAML
network: {bind_address: 127.0.0.1}
registration: {voxel_size_m: ${voxel}, threads: 2}
output: {directory: ${out}/daemon}
YAML

echo "== starting lidarfused"
"$bin/daemon/lidarfused" --config "$out/sim/daemon.yaml" >"$out/daemon.log" 2>&1 &
daemon=$!
trap 'kill "$daemon" 2>/dev/null || true' EXIT
for _ in $(seq 100); do
    grep -q "listening on UDP" "$out/daemon.log" && break
    sleep 0.1
done
grep -q "listening on UDP" "$out/daemon.log" || { cat "$out/daemon.log"; exit 1; }

echo "== replaying the capture through the daemon's sockets (recorded speed)"
"$bin/tools/lidarfuse" replay "$out/sim/capture.pcap" | grep -E "replay_(datagrams_sent|duration|send_errors)" || true
sleep 3  # let the last frames through fusion
kill -TERM "$daemon"
wait "$daemon" || true
trap - EXIT
grep -E "fusion|stopped" "$out/daemon.log" | tail -n 12

echo "== accuracy against ground truth (m, deg)"
# poses.csv is in the road frame (world.frame's default): the aligned and strict figures do
# not depend on it; --world road adds each sensor's height and up-direction error.
"$bin/tools/lidarfuse" eval --gt "$out/sim/ground_truth.csv" --poses "$out/daemon/poses.csv" --world road \
    --plot "$out/plots" | grep -E "alignment|matched_frames|_rmse_(trans|rot)|world_(height|up)_rmse"
echo "== outputs in $out (daemon log, poses.csv, extrinsics.yaml, plots)"

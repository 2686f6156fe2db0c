#!/usr/bin/env bash
# Does a recording reproduce its live run? Measured beside the daemon's own run-to-run
# spread on the same packets. One simulated capture is replayed at recorded speed into
# lidarfused twice, A (recording every datagram) and B, then A's recording into a third
# daemon, C. For each pair of runs: the pose differences where both fused the same scan,
# from 1 s after both had registered every sensor (median and worst, translation and
# rotation), and each run against the simulator's truth (`lidarfuse eval`, strict RMSE).
#   bench/record_replay_determinism.sh BUILD_DIR [SENSORS=2] [SECONDS=10] [SCENARIO=curve]
# Uses the simulator's ports (7502 + 2k) on 127.0.0.1 and DDS off; prints `name value unit`.
set -euo pipefail
build="$(cd "$1" && pwd)"; sensors="${2:-2}"; seconds="${3:-10}"; scenario="${4:-curve}"
tool="$build/tools/lidarfuse"; daemon="$build/daemon/lidarfused"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$tool" sim --scenario "$scenario" --sensors "$sensors" --seconds "$seconds" --quiet \
    --out "$work/sim" >/dev/null

# run NAME FEED [RECORD]: a daemon on the sim's station, fed by `lidarfuse replay FEED`.
run() {
    local name="$1" feed="$2" record="${3:-false}"
    cp "$work/sim/station.yaml" "$work/sim/$name.yaml"
    cat >>"$work/sim/$name.yaml" <<EOF
network: {bind_address: 127.0.0.1}
world: {frame: sensor}
output:
  directory: $work/$name
  dds: {enabled: false}
  record: {enabled: $record, directory: $work/rec}
EOF
    "$daemon" --config "$work/sim/$name.yaml" >"$work/$name.log" 2>&1 &
    local pid=$!
    for _ in $(seq 100); do grep -q "listening on UDP" "$work/$name.log" && break; sleep 0.1; done
    "$tool" replay --quiet --to 127.0.0.1 "$feed" >/dev/null
    sleep 2  # fusion catches up
    kill -TERM "$pid"
    wait "$pid"
}
run A "$work/sim/capture.pcap" true
run B "$work/sim/capture.pcap"
run C "$work/rec/$(ls "$work/rec")"

# diffs X Y: "mm deg" per scan both runs fused, from 1 s after both had every sensor.
diffs() {
    awk -F, '
        FNR == 1 { file++; next }
        { key = $2 "," $3
          if (!((file, $2) in first) || $3 < first[file, $2]) first[file, $2] = $3
          if (file == 1) { x[key] = $4; y[key] = $5; z[key] = $6; w[key] = $7; i[key] = $8; j[key] = $9; k[key] = $10 }
          else row[key] = $0 }
        END {
            for (f in first) if (first[f] > start) start = first[f]
            start += 1e9
            for (key in row) {
                if (!(key in x)) continue
                split(row[key], r, ",")
                if (r[3] + 0 < start) continue
                mm = sqrt((r[4] - x[key])^2 + (r[5] - y[key])^2 + (r[6] - z[key])^2) * 1e3
                # The angle of conj(q1) * q2 from its vector part: 1 - dot would lose the
                # small angles to rounding (quaternions are written to 1e-9).
                cw = w[key] * r[7] + i[key] * r[8] + j[key] * r[9] + k[key] * r[10]
                cx = w[key] * r[8] - r[7] * i[key] - (j[key] * r[10] - k[key] * r[9])
                cy = w[key] * r[9] - r[7] * j[key] - (k[key] * r[8] - i[key] * r[10])
                cz = w[key] * r[10] - r[7] * k[key] - (i[key] * r[9] - j[key] * r[8])
                if (cw < 0) cw = -cw
                print mm, 2 * atan2(sqrt(cx * cx + cy * cy + cz * cz), cw) * 45 / atan2(1, 1)
            }
        }' "$work/$1/poses.csv" "$work/$2/poses.csv"
}

# compare X Y: median and worst of those differences.
compare() {
    diffs "$1" "$2" >"$work/diffs"
    local n; n=$(wc -l <"$work/diffs")
    echo "$1_$2_poses $n poses"
    [ "$n" -gt 0 ] || return 0
    for c in 1 2; do
        local unit=mm; [ $c -eq 2 ] && unit=deg
        sort -g -k$c,$c "$work/diffs" | awk -v c=$c -v n="$n" -v name="$1_$2" -v unit=$unit '
            NR == int((n + 1) / 2) { med = $c } { last = $c }
            END { printf "%s_median %.4f %s\n%s_worst %.4f %s\n", name, med, unit, name, last, unit }'
    done
}
compare A B
compare A C
compare B C
for r in A B C; do
    "$tool" eval --gt "$work/sim/ground_truth.csv" --poses "$work/$r/poses.csv" |
        awk -v r="$r" '/strict/ { print "run_" r "_" $0 }'
done
grep -h "stopped:" "$work"/A.log "$work"/B.log "$work"/C.log | sed 's/^/# /'

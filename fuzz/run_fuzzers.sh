#!/usr/bin/env bash
# Configures and builds the libFuzzer harnesses (clang 14), builds their seed corpora from
# the sample captures, and runs each harness for a fixed time with a fixed seed.
#   fuzz/run_fuzzers.sh BUILD_DIR SECONDS_PER_HARNESS [harness ...]
# Harnesses: ouster_packets ouster_metadata pcap_reader ipv4_reassembler station_config
# pcd_reader ply_reader sensor_http point_cloud2 (default: all). Data: $LIDARFUSE_DATA_DIR/ouster (default
# ../shared/data/ouster beside the checkout; the point-cloud seeds come from ../real beside
# it); without it the harnesses start from an empty corpus (said so below).
# New inputs go to BUILD_DIR/fuzz-corpus/<harness>/ (kept between runs), crashes to
# BUILD_DIR/fuzz-findings/. Exits non-zero on the first crash, leak, time-out or broken
# invariant, printing the reproducer's path. Each run ends with libFuzzer's figures.
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
dir="$1"; seconds="$2"; shift 2
harnesses=("$@")
[ ${#harnesses[@]} -eq 0 ] && harnesses=(ouster_packets ouster_metadata pcap_reader ipv4_reassembler station_config
                                         pcd_reader ply_reader sensor_http point_cloud2)
data="${LIDARFUSE_DATA_DIR:-$top/../shared/data}/ouster"

export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$top}"
export CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-true}"
mkdir -p "$dir"
# LIDARFUSE_WERROR stays off here: the project's warning flags are GCC's (the harnesses
# themselves are always built with -Werror, see fuzz/CMakeLists.txt).
cmake -S "$top" -B "$dir" -G Ninja -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_C_COMPILER=clang-14 \
    -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -gline-tables-only" \
    -DCMAKE_C_FLAGS_DEBUG="-O1 -gline-tables-only" \
    -DCMAKE_CXX_FLAGS="-Wno-unknown-warning-option" -DLIDARFUSE_FUZZ=ON -DLIDARFUSE_WERROR=OFF \
    -DLIDARFUSE_BUILD_TESTS=OFF -DLIDARFUSE_BUILD_BENCH=OFF >"$dir.configure.log" 2>&1 ||
    { cat "$dir.configure.log"; exit 1; }
cmake --build "$dir" -j "$(nproc)" --target lidarfuse_fuzzers

seeds="$dir/fuzz-seeds"
rm -rf "$seeds"
if [ -d "$data" ]; then
    "$dir/fuzz/fuzz_seed_corpus" "$data" "$top" "$seeds"
else
    echo "fuzz: no sample data in $data: starting from empty corpora"
    for h in "${harnesses[@]}"; do mkdir -p "$seeds/$h"; done
fi

declare -A max_len=([ouster_packets]=65536 [ouster_metadata]=16384 [pcap_reader]=65536
                    [ipv4_reassembler]=16384 [station_config]=4096 [pcd_reader]=262144
                    [ply_reader]=262144 [sensor_http]=32768 [point_cloud2]=4096)
mkdir -p "$dir/fuzz-findings"
# One harness: its log in fuzz-findings/<harness>.log, non-zero on a finding.
fuzz_one() {
    local h="$1" corpus="$dir/fuzz-corpus/$1"
    mkdir -p "$corpus"
    # -rss_limit_mb: ASan+UBSan and 2048 x 128 scans need more than the default 2 GB only
    # if something leaks; keep the default. -timeout: one input may take at most 10 s.
    LIDARFUSE_FUZZ_BASE_DIR="$data" ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
        UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
        "$dir/fuzz/fuzz_$h" -seed=1 -max_total_time="$seconds" -max_len="${max_len[$h]}" \
        -timeout=10 -print_final_stats=1 -artifact_prefix="$dir/fuzz-findings/$h-" \
        "$corpus" "$seeds/$h" >"$dir/fuzz-findings/$h.log" 2>&1
}
# As many harnesses at once as there are cores (each is one process on one core, so each
# still gets its whole time), reported in order once its batch is done.
batch="${LIDARFUSE_FUZZ_JOBS:-$(nproc)}"
for ((i = 0; i < ${#harnesses[@]}; i += batch)); do
    group=("${harnesses[@]:i:batch}")
    declare -A pid=()
    for h in "${group[@]}"; do
        fuzz_one "$h" &
        pid[$h]=$!
    done
    failed=()
    for h in "${group[@]}"; do
        log="$dir/fuzz-findings/$h.log"
        echo "== fuzz_$h for $seconds s"
        if ! wait "${pid[$h]}"; then
            tail -n 60 "$log"
            failed+=("$h")
            continue
        fi
        grep -E "^#[0-9]+ +DONE|stat::number_of_executed_units|stat::average_exec_per_sec|stat::peak_rss_mb" "$log" || true
        echo "corpus $(ls "$dir/fuzz-corpus/$h" | wc -l) files"
    done
    unset pid
    for h in "${failed[@]}"; do
        echo "fuzz_$h FAILED: reproducer in $dir/fuzz-findings/ (log $dir/fuzz-findings/$h.log)"
    done
    [ ${#failed[@]} -eq 0 ] || exit 1
done

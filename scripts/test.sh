#!/usr/bin/env bash
# Installs everything, builds, and runs every test twice: an optimised build with warnings
# as errors, then an AddressSanitizer + UndefinedBehaviorSanitizer build.
# The sample captures come from $LIDARFUSE_DATA_DIR (default ../shared/data beside the
# checkout); tests that need them skip with a message where the folder is absent.
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
cd "$top"
"$top/scripts/setup.sh"

data_args=()
if [ -n "${LIDARFUSE_DATA_DIR:-}" ]; then data_args=(-DLIDARFUSE_DATA_DIR="$LIDARFUSE_DATA_DIR"); fi
jobs="$(nproc)"
start=$(date +%s)
stage() { echo "== $1 (at $(( $(date +%s) - start )) s)"; }

# The house format first: a few seconds, and a deviation is named before any build starts.
stage "format (clang-format, .clang-format)"
"$top/scripts/check_format.sh"

# Unity builds (eight files to a unit; the tests one executable per folder): the same code
# and the same tests, compiled in about half the time from nothing. A name that two files
# of one unit both define fails here first (see tests/CMakeLists.txt).
unity=(-DLIDARFUSE_UNITY_BUILD=ON -DLIDARFUSE_TEST_BUNDLES=ON)

# -g1 here and in the sanitizer trees: line tables, which is what perf's and the sanitizers'
# reports print (file:line of every frame); full debug info of the Eigen-heavy units costs a
# third of the compile time and serves only a debugger's variable views.
stage "release build (RelWithDebInfo at -O2 -g1, -Werror)"
"$top/scripts/build.sh" "$top/build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" \
    "${unity[@]}" "${data_args[@]}"
# The house naming rules (.clang-tidy) on every unit of that tree, which includes the
# generated message headers its units need.
stage "naming (clang-tidy, .clang-tidy)"
"$top/scripts/check_naming.sh" "$top/build"
# The live view's test client (Foxglove's npm packages, exactly package-lock.json's
# versions) into the build folder; lidarfused_foxglove_test skips without it.
stage "foxglove test client (npm ci)"
"$top/tests/foxglove/install.sh" "$top/build"
stage "release tests"
ctest --test-dir "$top/build" -j "$jobs" --output-on-failure --timeout 600

# The tests' own code at -Og: half of this tree's compile time was their files (gtest's and
# Eigen's templates optimised at -O1), which run little of what the tests spend; the
# libraries and executables they test stay at -O1 (bench/BENCHMARK.md, "The tests' own code
# at -Og under the sanitizers").
stage "sanitizer build (ASan + UBSan, -O1, the tests' own code -Og, assertions on)"
"$top/scripts/build.sh" "$top/build-asan" -DCMAKE_BUILD_TYPE=Debug \
    -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DCMAKE_C_FLAGS_DEBUG="-O1 -g1" -DLIDARFUSE_TEST_CODE_OPTIMIZATION=-Og \
    -DLIDARFUSE_SANITIZE=address,undefined -DLIDARFUSE_BUILD_BENCH=OFF "${unity[@]}" "${data_args[@]}"
"$top/tests/foxglove/install.sh" "$top/build-asan"
stage "sanitizer tests"
# Started longest first in the order of the release run's durations (ctest's cost data),
# so that no long test is left to run alone at the end; a tree with data of its own keeps it.
asan_costs="$top/build-asan/Testing/Temporary/CTestCostData.txt"
release_costs="$top/build/Testing/Temporary/CTestCostData.txt"
if [ ! -f "$asan_costs" ] && [ -f "$release_costs" ]; then
    mkdir -p "$(dirname "$asan_costs")"
    cp "$release_costs" "$asan_costs"
fi
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1 \
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir "$top/build-asan" -j "$jobs" --output-on-failure --timeout 900

# ThreadSanitizer: only the tests whose code runs several threads (queues, synchroniser,
# UDP receiver, the daemon and the reliability tests that drive it). OMP_NUM_THREADS=1:
# Debian's libgomp is not built with TSan, so its worker threads' synchronisation would be
# invisible to it and reported as races; with one OpenMP thread there are none, and every
# thread of our own (receivers, sync, fusion, initial registration, output, DDS) still
# runs. tests/reliability/tsan.supp names the other uninstrumented libraries (Embree and
# TBB in the simulator), never our code.
# lidarfused_test runs only its config check here: its replay and live tests subscribe
# over DDS inside the test process, and Debian's Cyclone DDS (libddsc) is not built with
# TSan, so its own thread handling is reported as races (seen: ddsrt_mutex_destroy).
# The daemon's threads are exercised under TSan by sensor_outage_test instead (DDS off).
stage "thread sanitizer build (pipeline tests)"
# lidarfused_foxglove_test subscribes over Foxglove's WebSocket from Node, not DDS: the
# daemon's own threads (lf-output handing samples to lf-foxglove) are what TSan watches.
tsan_tests=(drop_oldest_queue_test doorbell_test frame_synchroniser_test net_udp_receiver_test
            lidarfused_test sensor_outage_test malformed_config_test recorder_test sensor_hostname_test
            lidarfused_foxglove_test)
CCACHE_BASEDIR="$top" CCACHE_NOHASHDIR=true cmake -S "$top" -B "$top/build-tsan" -G Ninja \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" \
    -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DLIDARFUSE_WERROR=ON -DLIDARFUSE_SANITIZE=thread \
    -DLIDARFUSE_BUILD_BENCH=OFF -DLIDARFUSE_UNITY_BUILD=ON -DLIDARFUSE_TEST_CODE_OPTIMIZATION=-Og \
    "${data_args[@]}" >"$top/build-tsan.configure.log" 2>&1 ||
    { cat "$top/build-tsan.configure.log"; exit 1; }
CCACHE_BASEDIR="$top" CCACHE_NOHASHDIR=true cmake --build "$top/build-tsan" -j "$jobs" --target "${tsan_tests[@]}"
"$top/tests/foxglove/install.sh" "$top/build-tsan"
stage "thread sanitizer tests"
for t in "${tsan_tests[@]}"; do
    filter="*"
    [ "$t" = lidarfused_test ] && filter="Lidarfused.CheckAcceptsAValidConfigAndListsEveryProblemOfABadOne"
    echo "-- $t ($filter)"
    OMP_NUM_THREADS=1 \
    TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$top/tests/reliability/tsan.supp" \
        LIDARFUSE_DATA_DIR="${LIDARFUSE_DATA_DIR:-$top/../shared/data}" \
        timeout 900 "$top/build-tsan/tests/$t" --gtest_brief=1 --gtest_filter="$filter"
done

# The host wall-clock jump (host_clock_jump_test re-runs itself under its LD_PRELOAD shim,
# tests/reliability/realtime_shift_shim.c, built without sanitizers), the mode change
# (ingest_faults_test) and a sensor clock off by 37 s (clock_skew_test) drive the daemon's
# threads too: the same TSan build, DDS off.
stage "thread sanitizer: host clock jump, mode change, sensor clock skew"
tsan_clock_tests=(host_clock_jump_test ingest_faults_test clock_skew_test)
CCACHE_BASEDIR="$top" CCACHE_NOHASHDIR=true cmake --build "$top/build-tsan" -j "$jobs" --target "${tsan_clock_tests[@]}"
for t in "${tsan_clock_tests[@]}"; do
    echo "-- $t"
    OMP_NUM_THREADS=1 \
    TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$top/tests/reliability/tsan.supp" \
        LIDARFUSE_DATA_DIR="${LIDARFUSE_DATA_DIR:-$top/../shared/data}" \
        timeout 900 "$top/build-tsan/tests/$t" --gtest_brief=1
done

# libFuzzer (clang 14): every harness in fuzz/ for 20 s with a fixed seed, from seeds
# built out of the sample captures; longer runs and their figures: fuzz/README.md.
stage "fuzzers (clang, ASan + UBSan, 20 s each)"
"$top/fuzz/run_fuzzers.sh" "$top/build-fuzz" 20

echo "== all tests passed in $(( $(date +%s) - start )) s"

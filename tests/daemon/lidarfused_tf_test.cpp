// lidarfused's tf as tf2 sees it: a replay with a sensor silenced for 1 s and stamps on the
// host's clock, everything published fed to a model of tf2's rules (tf2_model.hpp).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>

#include "tests/daemon/lidarfused_test_support.hpp"

namespace lidarfuse {
namespace {

using namespace lidarfused_test;  // NOLINT(google-build-using-namespace): the tests' own helpers
using ::testing::HasSubstr;

// A sensor silenced for 1 s of a replay, stamps on the host's clock: tf2 resolves every
// cloud's stamp for every sensor in it (the silenced one is left out of the frames it
// misses, never sent with stamp 0), and every stamp is CLOCK_REALTIME of this run.
TEST(Lidarfused, TfResolvesEveryCloudWithASensorSilencedAndHostStamps) {
    test::use_loopback_dds();
    test::TempDir dir("lfd-tf2");
    const auto d = dir.path();
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 2 --seconds 5 "
                                    "--fault silence:lidar1:3:1 --out " +
                                    (d / "sim").string(),
                                &out),
              0)
        << out;
    // A port range of its own (the other tests use 30000+ and 42000+).
    const auto p0 = test::port_block();
    const int domain = test::unique_domain_id();
    std::ofstream(d / "sim" / "daemon.yaml")
        << "station: tf2\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << p0 + 2
        << ", metadata: lidar1.json}\n"
        // The world frame is not what this test is about: in the sensor frame every frame is
        // published from the first, so lidar1's silence falls inside what is seen. Under the
        // road default a loaded machine fixed the road only 3 frames before the end.
        << "network: {bind_address: 127.0.0.1}\nworld: {frame: sensor}\noutput:\n  directory: "
        << (d / "out").string() << "\n  stamp: host\n"
        << "  dds: {domain_id: " << domain
        << ", frame_id: station_world, diagnostics_period_ms: 200}\n";
    DaemonReaders readers(domain);
    DdsSeen seen;
    const std::int64_t started_ns = daemon::realtime_ns();
    FedRun run;
    ASSERT_NO_FATAL_FAILURE(run_fed_daemon(
        d / "sim" / "daemon.yaml", d / "daemon.log",
        test::tool_path() + " replay " + (d / "sim" / "capture.pcap").string() +
            " --port-map 7502:" + std::to_string(p0) + " --port-map 7504:" + std::to_string(p0 + 2),
        12000, &readers, &seen, &run));
    const std::int64_t stopped_ns = daemon::realtime_ns();
    const std::string text = read_text(d / "daemon.log");
    ASSERT_FALSE(seen.frames.empty()) << text;
    const std::size_t misses = expect_every_cloud_resolves(seen);
    EXPECT_LE(misses, 1u);  // at most lidar1's first frame on tf (the root's is its own stamp)
    EXPECT_EQ(seen.tf_messages, frames_with_tf(seen));
    // The host's clock: every stamp within this run (the simulated sensors' clock is not).
    EXPECT_GE(seen.min_stamp, started_ns);
    EXPECT_LE(seen.max_stamp, stopped_ns);
    // The silence is covered: frames with lidar1, then without it, then with it again.
    std::vector<bool> has1;
    for (const auto& f : seen.frames) {
        has1.push_back(std::find(f.stamped.begin(), f.stamped.end(), "lidar1") != f.stamped.end());
    }
    const auto first_with = std::find(has1.begin(), has1.end(), true);
    const auto gap = std::find(first_with, has1.end(), false);
    const auto back = std::find(gap, has1.end(), true);
    std::printf("tf2 model: %zu frames, lidar1 in %td, tf2 misses in a first frame %zu\n",
                seen.frames.size(), std::count(has1.begin(), has1.end(), true), misses);
    if (first_with == has1.end()) GTEST_SKIP() << "lidar1 was not registered before the silence";
    // The replay runs at recorded speed and the stamps are the host's receive times, so the
    // silence (capture time 3-4 s) starts about 3 s after the first frame's stamp. When
    // lidar1 is first fused later than 2.5 s after it (its initial registration took that
    // long: a loaded machine, a sanitizer build), the silence may lie before its first frame
    // and no gap can be seen; the tf checks above still ran.
    const std::int64_t first_with_ns =
        seen.frames[static_cast<std::size_t>(first_with - has1.begin())].stamp_ns;
    if (first_with_ns - seen.frames.front().stamp_ns > 2'500'000'000LL) {
        GTEST_SKIP() << "lidar1 first fused "
                     << 1e-9 * (first_with_ns - seen.frames.front().stamp_ns)
                     << " s into the replay, too late to see its silence";
    }
    EXPECT_NE(gap, has1.end()) << "no frame without lidar1 during its silence";
    EXPECT_NE(back, has1.end()) << "lidar1 did not come back after its silence";
}

}  // namespace
}  // namespace lidarfuse

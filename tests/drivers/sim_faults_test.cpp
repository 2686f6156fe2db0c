// Fault hooks: each one does what its flag says, visibly to the ingest's counters.
#include <gtest/gtest.h>

#include <map>
#include <stdexcept>

#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/sim/simulator.hpp"

namespace lidarfuse::sim {
namespace {

struct Collected {
    std::vector<SimDatagram> datagrams;
    std::map<int, ouster::AssemblyCounters> counters;
    std::map<int, std::vector<ouster::LidarScan>> scans;
    std::size_t rendered = 0;
};

class CollectSink : public DatagramSink {
public:
    void write(const SimDatagram& d) override { out.push_back(d); }
    std::vector<SimDatagram> out;
};

Collected run(const std::vector<std::string>& faults,
              ouster::UdpProfileLidar profile = ouster::UdpProfileLidar::kLegacy) {
    SimParams p;
    p.scenario = Scenario::kStraight;
    p.sensors = 2;
    p.seconds = 0.3;
    p.columns_per_frame = 512;
    p.profile = profile;
    p.traffic = false;
    p.threads = 2;
    for (const auto& f : faults) parse_fault(f, p.sensors, &p.faults);
    Simulator sim(p);
    CollectSink sink;
    Collected c;
    c.rendered = sim.run(sink).packets_rendered;
    c.datagrams = std::move(sink.out);
    for (int k = 0; k < 2; ++k) {
        ouster::ScanAssembler assembler(
            sim.rigs()[k].info(), {},
            [&c, k](const ouster::LidarScan& s) { c.scans[k].push_back(s); });
        for (const auto& d : c.datagrams) {
            if (d.sensor == k) assembler.add_packet(d.payload.data(), d.payload.size());
        }
        assembler.flush();
        c.counters[k] = assembler.counters();
    }
    return c;
}

TEST(SimFaults, SpecsAreParsedAndBadOnesRejected) {
    FaultPlan plan;
    parse_fault("drop:0.1", 2, &plan);
    parse_fault("silence:lidar1:1.5:2", 2, &plan);
    parse_fault("clock-offset:lidar0:-0.25", 2, &plan);
    EXPECT_DOUBLE_EQ(plan.drop.share, 0.1);
    EXPECT_EQ(plan.drop.sensor, -1);
    ASSERT_EQ(plan.silences.size(), 1u);
    EXPECT_TRUE(plan.silenced(1, 2.0));
    EXPECT_FALSE(plan.silenced(1, 3.5));
    EXPECT_FALSE(plan.silenced(0, 2.0));
    EXPECT_EQ(plan.clock_offset_ns(0), -250'000'000);
    for (const char* bad :
         {"drop", "drop:1.5", "drop:x", "bogus:0.1", "silence:lidar2:1:1", "init-id:lidar0",
          "duplicate:0.1:lidar0:extra", "clock-offset:lidar0:1s"}) {
        EXPECT_THROW(parse_fault(bad, 2, &plan), std::invalid_argument) << bad;
    }
}

TEST(SimFaults, CleanRunAssemblesEveryFrame) {
    const auto c = run({});
    EXPECT_EQ(c.datagrams.size(), c.rendered);
    for (int k = 0; k < 2; ++k) {
        EXPECT_EQ(c.counters.at(k).frames_complete, 6u);
        EXPECT_EQ(c.counters.at(k).frames_incomplete, 0u);
    }
}

TEST(SimFaults, DropDuplicateTruncateShowInTheCounters) {
    const auto c = run({"drop:0.1:lidar0", "duplicate:0.1:lidar1", "truncate:0.05:lidar1"});
    const auto& c0 = c.counters.at(0);
    const auto& c1 = c.counters.at(1);
    const double dropped = 192.0 - static_cast<double>(c0.lidar_packets);
    EXPECT_NEAR(dropped, 19.2, 12.0);
    EXPECT_GT(c0.frames_incomplete, 0u);
    EXPECT_GT(c0.missing_columns, 0u);
    EXPECT_NEAR(static_cast<double>(c1.duplicate_packets), 19.2, 12.0);
    EXPECT_NEAR(static_cast<double>(c1.bad_size), 9.6, 8.0);
    EXPECT_GT(c1.bad_size, 0u);
}

TEST(SimFaults, ReorderKeepsFramesCompleteButChangesTheOrder) {
    const auto c = run({"reorder:0.1"});
    int inversions = 0;
    std::map<int, std::uint64_t> last_ts;
    const ouster::PacketFormat f(ouster::UdpProfileLidar::kLegacy, 64, 16);
    for (std::size_t i = 0; i + 1 < c.datagrams.size(); ++i) {
        const auto& d = c.datagrams[i];
        const std::uint64_t ts = f.column_timestamp_ns(f.column(d.payload.data(), 0));
        if (last_ts.count(d.sensor) && ts < last_ts[d.sensor]) ++inversions;
        last_ts[d.sensor] = ts;
        EXPECT_LE(d.capture_ns, c.datagrams[i + 1].capture_ns);  // capture order in time
    }
    EXPECT_GT(inversions, 10);
    for (int k = 0; k < 2; ++k) {
        EXPECT_EQ(c.counters.at(k).late_packets, 0u);
        EXPECT_EQ(c.counters.at(k).frames_complete, 6u);
    }
}

TEST(SimFaults, SilenceRemovesASensorForAWhile) {
    const auto c = run({"silence:lidar1:0.1:0.1"});
    for (const auto& d : c.datagrams) {
        const double t = static_cast<double>(d.capture_ns - kEpochNs) * 1e-9;
        if (d.sensor == 1) {
            EXPECT_FALSE(t > 0.101 && t < 0.199) << t;
        }
    }
    EXPECT_EQ(c.counters.at(0).frames_complete, 6u);
    EXPECT_LT(c.counters.at(1).lidar_packets, 192u - 50u);
}

TEST(SimFaults, ClockOffsetShiftsOnlyThatSensorsTimestamps) {
    const auto clean = run({});
    const auto shifted = run({"clock-offset:lidar1:0.5"});
    ASSERT_EQ(clean.scans.at(1).size(), shifted.scans.at(1).size());
    EXPECT_EQ(shifted.scans.at(1)[0].timestamp_ns[7],
              clean.scans.at(1)[0].timestamp_ns[7] + 500'000'000u);
    EXPECT_EQ(shifted.scans.at(0)[0].timestamp_ns[7], clean.scans.at(0)[0].timestamp_ns[7]);
    EXPECT_EQ(shifted.datagrams.front().capture_ns, clean.datagrams.front().capture_ns);
}

TEST(SimFaults, InitIdChangeMakesTheAssemblerReset) {
    const auto c = run({"init-id:lidar0:0.12"}, ouster::UdpProfileLidar::kRng19Rfl8Sig16Nir16);
    EXPECT_GE(c.counters.at(0).resets, 1u);
    EXPECT_EQ(c.counters.at(1).resets, 0u);
    const auto& scans = c.scans.at(0);
    ASSERT_GE(scans.size(), 2u);
    EXPECT_NE(scans.front().init_id, scans.back().init_id);
}

}  // namespace
}  // namespace lidarfuse::sim

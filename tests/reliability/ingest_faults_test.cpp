// Ingest-level rows of the fault table that the drivers' unit tests do not already cover
// (tests/reliability/FAULTS.md maps every row): foreign sources and serials, a sensor whose
// profile or mode changed under its metadata (at the assembler, and in the daemon: flagged,
// reported, not fused until its data fits again), and column timestamps anywhere in
// 0..2^64-1. The ModeCheck's own cases: mode_mismatch_test.cpp.
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "daemon/dds_messages.hpp"
#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/packet_format.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/sensor_router.hpp"
#include "drivers/ouster/xyz_lut.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "drivers/pcap/pcap_writer.hpp"
#include "tests/reliability/packet_fixture.hpp"
#include "tests/reliability/station_fixture.hpp"

namespace lidarfuse::reliability {
namespace {

using ouster::PacketFormat;
using ouster::SensorInfo;
using ouster::UdpProfileLidar;

// Row "packet from an unknown source address or serial": dropped, counted as foreign.
TEST(IngestFaults, ForeignSourceAddressAndForeignSerialAreNotTakenForTheSensor) {
    const SensorInfo a = sensor(kRng19, 1024, kSerial, 7502);
    const SensorInfo b = sensor(kRng19, 1024, kSerial + 1, 7502);
    const PacketFormat format(a);
    const auto pa = packet(format, 1, 0, kSerial, 1'000'000, 48'828);
    const auto foreign = packet(format, 1, 0, 123456789, 1'000'000, 48'828);

    // Two sensors share port 7502, a's address is configured: another address is foreign.
    ouster::SensorRouter router({{a, 0x0A000001u}, {b, std::nullopt}});
    EXPECT_EQ(router.route(0x0A000001u, 7502, pa.data(), pa.size()), 0);
    EXPECT_EQ(router.route(0x0A000099u, 7502, foreign.data(), foreign.size()),
              ouster::SensorRouter::kUnassigned);
    EXPECT_EQ(router.route(0x0A000001u, 7999, pa.data(), pa.size()),
              ouster::SensorRouter::kUnassigned);
    EXPECT_EQ(router.counters().unassigned, 2u);

    // A sensor alone on its port: a packet with another serial reaches its assembler
    // (rule 6), which refuses it as the wrong sensor, counts it, and assembles nothing.
    int frames = 0;
    ouster::ScanAssembler assembler(a, {}, [&](const ouster::LidarScan&) { ++frames; });
    EXPECT_EQ(assembler.add_packet(foreign.data(), foreign.size()),
              ouster::PacketOutcome::kWrongProfile);
    assembler.flush();
    EXPECT_EQ(assembler.counters().bad_profile, 1u);
    EXPECT_EQ(assembler.counters().lidar_packets, 0u);
    EXPECT_EQ(frames, 0);
}

// Row "profile or mode changed on the sensor": a profile change changes the packet size
// (every packet counted bad, no scan ever emitted, so the sensor goes LOST); a mode change
// 1024 -> 512 columns keeps the size, and shows as frames that never complete, each
// missing the columns 512..1023 it was told to expect.
TEST(IngestFaults, ProfileOrModeChangedUnderTheMetadataIsCountedAndNeverComplete) {
    const SensorInfo configured = sensor(kRng19, 1024, kSerial, 7502);
    {
        const PacketFormat legacy(sensor(UdpProfileLidar::kLegacy, 1024, 0, 7502));
        int frames = 0;
        ouster::ScanAssembler assembler(configured, {},
                                        [&](const ouster::LidarScan&) { ++frames; });
        for (int p = 0; p < 64; ++p) {
            const auto pkt = packet(legacy, 1, p * 16, 0, 0, 48'828);
            EXPECT_EQ(assembler.add_packet(pkt.data(), pkt.size()),
                      ouster::PacketOutcome::kWrongSize);
        }
        assembler.flush();
        EXPECT_EQ(assembler.counters().bad_size, 64u);
        EXPECT_EQ(frames, 0);
        // One frame's worth of wrong sizes is not yet a profile change (three are).
        EXPECT_FALSE(assembler.mode_check().mismatch());
    }
    {
        const PacketFormat now(sensor(kRng19, 512, kSerial, 7502));
        std::vector<double> completeness;
        ouster::ScanAssembler assembler(configured, {}, [&](const ouster::LidarScan& s) {
            completeness.push_back(s.completeness());
        });
        for (std::uint32_t frame = 1; frame <= 4; ++frame) {
            for (int p = 0; p < 32; ++p) {
                const auto pkt = packet(now, frame, p * 16, kSerial, frame * 50'000'000ull, 97'656);
                assembler.add_packet(pkt.data(), pkt.size());
            }
        }
        assembler.flush();
        ASSERT_EQ(completeness.size(), 4u);
        for (double c : completeness) EXPECT_DOUBLE_EQ(c, 0.5);
        EXPECT_EQ(assembler.counters().frames_complete, 0u);
        EXPECT_EQ(assembler.counters().frames_incomplete, 4u);
        EXPECT_EQ(assembler.counters().missing_columns, 4u * 512u);
        // The mode change itself is seen (columns twice as far apart as 1024x20 says).
        EXPECT_TRUE(assembler.mode_check().mismatch());
        EXPECT_EQ(assembler.counters().mode_mismatch_frames, 4u);
        EXPECT_EQ(assembler.counters().mode_mismatches, 1u);
        EXPECT_EQ(assembler.mode_check().last_disagreement().evidence,
                  ouster::ModeEvidence::kColumnSpacing);
    }
}

// One datagram of a capture, kept for rewriting.
struct Record {
    std::int64_t t_ns;
    std::uint32_t src_ip, dst_ip;
    std::uint16_t src_port, dst_port;
    std::vector<std::uint8_t> bytes;
};

std::vector<Record> read_records(const std::filesystem::path& file) {
    pcap::PcapReader reader(file);
    std::vector<Record> out;
    pcap::UdpDatagram d;
    while (reader.next(&d)) {
        out.push_back({d.timestamp_ns,
                       d.src_ip,
                       d.dst_ip,
                       d.src_port,
                       d.dst_port,
                       {d.data, d.data + d.size}});
    }
    return out;
}

// The same station simulated twice (same scene, seed and clocks), once at 512x20 and once
// at 1024x20; the replayed capture is the 512x20 one, except that lidar1 (port 7504)
// sends its 1024x20 packets from 2 s to 4.5 s: someone switched its mode on its web page
// and back. The daemon runs with the 512x20 metadata. lidar1 must be flagged
// MODE_MISMATCH (log ERROR and diagnostics saying what was seen against the metadata),
// not fused meanwhile, and OK again without a restart; lidar0 keeps fusing throughout.
TEST(IngestFaults, ModeChangeOnOneSensorIsReportedNotFusedAndItResumesWhenItFitsAgain) {
    test::TempDir sim512("mode-512"), sim1024("mode-1024"), out("mode-out");
    simulate(sim512.path(), 7.0, {});
    simulate(sim1024.path(), 7.0, {}, 2, "1024x20");
    const auto base = read_records(sim512.path() / "capture.pcap");
    const auto other = read_records(sim1024.path() / "capture.pcap");
    ASSERT_FALSE(base.empty());
    ASSERT_FALSE(other.empty());
    constexpr std::uint16_t kLidar1Port = 7504;
    const auto in_change = [](std::int64_t t, std::int64_t t0) {
        return t - t0 >= 2'000'000'000 && t - t0 < 4'500'000'000;
    };
    // (capture time from the start of its own file, record): both files start together.
    std::vector<std::pair<std::int64_t, const Record*>> mixed;
    for (const auto& r : base) {
        if (!(r.dst_port == kLidar1Port && in_change(r.t_ns, base.front().t_ns))) {
            mixed.emplace_back(r.t_ns - base.front().t_ns, &r);
        }
    }
    for (const auto& r : other) {
        if (r.dst_port == kLidar1Port && in_change(r.t_ns, other.front().t_ns)) {
            mixed.emplace_back(r.t_ns - other.front().t_ns, &r);
        }
    }
    std::stable_sort(mixed.begin(), mixed.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    const auto capture = out.path() / "mode_change.pcap";
    {
        pcap::PcapWriterOptions options;
        options.fragment = false;
        pcap::PcapWriter writer(capture, options);
        for (const auto& [t, r] : mixed) {
            writer.write_udp(base.front().t_ns + t, r->src_ip, r->src_port, r->dst_ip, r->dst_port,
                             r->bytes.data(), r->bytes.size());
        }
        writer.close();
    }

    // The ingest log goes to a string as well (the Pipeline takes the registered "ingest").
    std::ostringstream log_text;
    auto ingest_log = std::make_shared<spdlog::logger>(
        "ingest", std::make_shared<spdlog::sinks::ostream_sink_mt>(log_text));
    spdlog::drop("ingest");
    spdlog::register_logger(ingest_log);
    struct DropLogger {
        ~DropLogger() { spdlog::drop("ingest"); }
    } drop_logger;

    const int slot = 0;
    daemon::Pipeline pipeline(station_config(sim512.path(), out.path() / "daemon", slot));
    pipeline.start();
    BackgroundReplay replay(capture, "--to 127.0.0.1" + port_map(slot, 2));
    struct Seen {
        daemon::SensorState state;
        std::uint64_t frames_synchronised;
        double at_s;
    };
    std::vector<Seen> lidar1;
    std::vector<daemon::SensorState> lidar0_states;
    std::optional<daemon::PipelineStats> while_mismatched;
    const auto start = std::chrono::steady_clock::now();
    while (!replay.done()) {
        const auto st = pipeline.stats();
        const double t =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (lidar1.empty() || lidar1.back().state != st.sensors[1].state) {
            lidar1.push_back({st.sensors[1].state, st.frames_synchronised, t});
        }
        if (lidar0_states.empty() || lidar0_states.back() != st.sensors[0].state) {
            lidar0_states.push_back(st.sensors[0].state);
        }
        if (st.sensors[1].state == daemon::SensorState::kModeMismatch) while_mismatched = st;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_EQ(replay.join(), 0) << replay.output();
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    const auto st = pipeline.stats();
    pipeline.stop();
    std::string story = "lidar1:";
    for (const auto& s : lidar1)
        story += std::string(" ") + daemon::to_string(s.state) + "@" + std::to_string(s.at_s);
    SCOPED_TRACE(story + "\nlog:\n" + log_text.str());

    // lidar1: OK, then MODE_MISMATCH, then OK again (possibly LOST in between: its last
    // fused scan was 2.5 s earlier), in that order.
    std::size_t k = 0;
    for (daemon::SensorState want :
         {daemon::SensorState::kOk, daemon::SensorState::kModeMismatch, daemon::SensorState::kOk}) {
        while (k < lidar1.size() && lidar1[k].state != want) ++k;
        ASSERT_LT(k, lidar1.size())
            << "lidar1 never reached " << daemon::to_string(want) << " in order";
        ++k;
    }
    const auto& s1 = st.sensors[1];
    EXPECT_EQ(s1.mode_mismatches, 1u);
    EXPECT_GE(s1.mode_mismatch_frames, 30u);  // 2.5 s at 20 Hz = 50 frames, give or take the edges
    EXPECT_GE(s1.scans_mode_rejected, 30u);
    EXPECT_NE(s1.mode_seen.find("column_spacing"), std::string::npos) << s1.mode_seen;
    EXPECT_NE(s1.mode_seen.find("metadata (512x20) says columns 0..511"), std::string::npos)
        << s1.mode_seen;
    // lidar0 was never suspected and never lost; frames kept leaving the synchroniser
    // while lidar1 was flagged (at least half the 20 Hz rate).
    EXPECT_EQ(st.sensors[0].mode_mismatch_frames, 0u);
    EXPECT_EQ(st.sensors[0].mode_mismatches, 0u);
    ASSERT_FALSE(lidar0_states.empty());
    for (std::size_t i = 1; i < lidar0_states.size(); ++i) {  // [0]: LOST until its first scan
        EXPECT_NE(lidar0_states[i], daemon::SensorState::kModeMismatch);
        EXPECT_NE(lidar0_states[i], daemon::SensorState::kLost);
    }
    const auto flagged = std::find_if(lidar1.begin(), lidar1.end(), [](const Seen& s) {
        return s.state == daemon::SensorState::kModeMismatch;
    });
    const auto cleared = std::find_if(flagged, lidar1.end(), [](const Seen& s) {
        return s.state != daemon::SensorState::kModeMismatch;
    });
    ASSERT_NE(cleared, lidar1.end());
    const double flagged_s = cleared->at_s - flagged->at_s;
    EXPECT_GT(flagged_s, 1.5);
    EXPECT_GE(static_cast<double>(cleared->frames_synchronised - flagged->frames_synchronised),
              0.5 * 20.0 * flagged_s);
    EXPECT_GT(st.frames_fused, 0u);
    // Reported: an ERROR naming the sensor and what was seen, an INFO when it fits again
    // (normal life again), and the diagnostics message while it was flagged.
    EXPECT_NE(log_text.str().find(
                  "[error] lidar1: data does not match its metadata, not fused until it does"),
              std::string::npos);
    EXPECT_NE(log_text.str().find(
                  "[info] lidar1: data matches its metadata (512x20 RNG19_RFL8_SIG16_NIR16) again"),
              std::string::npos);
    EXPECT_EQ(log_text.str().find("lidar0: data does not match"), std::string::npos);
    ASSERT_TRUE(while_mismatched);
    daemon::DiagnosticsBuilder diagnostics({"test", "map", {"lidar0", "lidar1"}, 0});
    const auto& array = diagnostics.build(*while_mismatched, 0);
    ASSERT_GE(array.status._length, 2u);
    const auto& status = array.status._buffer[1];
    EXPECT_EQ(status.level, 2);  // ERROR
    EXPECT_NE(std::string(status.message).find("MODE_MISMATCH: column_spacing"), std::string::npos)
        << status.message;
    std::map<std::string, std::string> values;
    for (std::uint32_t v = 0; v < status.values._length; ++v)
        values[status.values._buffer[v].key] = status.values._buffer[v].value;
    EXPECT_EQ(values["state"], "MODE_MISMATCH");
    EXPECT_EQ(values["mode_mismatches"], "1");
    EXPECT_NE(values["mode_seen"].find("metadata (512x20)"), std::string::npos);
}

// Found by fuzz/fuzz_ouster_packets: column timestamps far apart (a corrupted column, a
// clock jump inside a frame) made point_times_s() overflow a signed subtraction
// (undefined behaviour; UBSan aborts). Now every point gets a finite time relative to
// the reference, with the right sign.
TEST(IngestFaults, ColumnTimestampsAnywhereInTheRangeGiveFinitePointTimes) {
    const SensorInfo info = sensor(kRng19, 512, kSerial, 7502);
    const PacketFormat format(info);
    const ouster::XyzLut lut = ouster::make_xyz_lut(info);
    constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();
    for (const auto& [t0, step] : std::vector<std::pair<std::uint64_t, std::uint64_t>>{
             {0, kMax / 600}, {kMax - 512, 1}, {1ull << 63, 1ull << 50}, {5, 0}}) {
        std::vector<std::vector<float>> times;
        ouster::ScanCloud cloud;
        ouster::ScanAssembler assembler(info, {}, [&](const ouster::LidarScan& scan) {
            ASSERT_TRUE(ouster::project_scan(scan, lut, {}, &cloud));
            times.emplace_back();
            ouster::point_times_s(cloud, ouster::scan_reference_time_ns(scan), &times.back());
        });
        for (int p = 0; p < 32; ++p) {
            const auto pkt = packet(format, 3, p * 16, kSerial, t0, step);
            assembler.add_packet(pkt.data(), pkt.size());
        }
        ASSERT_EQ(times.size(), 1u);
        ASSERT_EQ(times[0].size(), 512u * 64u);
        for (float t : times[0]) {
            ASSERT_TRUE(std::isfinite(t));
            ASSERT_GE(t, 0.0f);  // column 0 is the reference and the earliest
        }
    }
    // A reference after the points: negative times, no wrap-around.
    ouster::ScanCloud cloud;
    cloud.columns = 2;
    cloud.rows = 1;
    cloud.num_points = 2;
    cloud.pixel_index = {0, 1};
    cloud.column_timestamp_ns = {0, kMax};
    std::vector<float> t;
    ouster::point_times_s(cloud, kMax, &t);
    ASSERT_EQ(t.size(), 2u);
    EXPECT_LT(t[0], -1e9f);
    EXPECT_EQ(t[1], 0.0f);
}

}  // namespace
}  // namespace lidarfuse::reliability

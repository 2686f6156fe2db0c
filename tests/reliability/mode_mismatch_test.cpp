// Row "profile or mode changed on the sensor", at the assembler: the ModeCheck
// (drivers/ouster/mode_check.hpp) tells from column ids, column timestamps and packet
// sizes that the data no longer matches the metadata, flags the sensor after three
// disagreeing frames, says what it saw, and trusts it again after three agreeing ones.
// Faults that are not a mode change (loss, reorder, an azimuth window, a clock jump
// inside one frame, the real sample captures) must never flag it.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/sensor_router.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "tests/reliability/packet_fixture.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::reliability {
namespace {

using ouster::ModeCheck;
using ouster::ModeEvidence;
using ouster::PacketFormat;
using ouster::ScanAssembler;
using ouster::SensorInfo;

// What the assembler's EmitFn saw for each frame: was it to be rejected, was the sensor flagged.
struct Emitted {
    bool rejected;
    bool flagged;
};

struct Rig {
    explicit Rig(const SensorInfo& info)
        : assembler(info, {}, [this](const ouster::LidarScan&) {
              emitted.push_back(
                  {assembler.mode_check().reject_last_frame(), assembler.mode_check().mismatch()});
          }) {}
    // Frames [first, first + count) of a sensor running in `mode` (columns x fps), every
    // packet in order, column timestamps on the sensor's true clock.
    void send(const SensorInfo& mode, std::uint32_t first, std::uint32_t count, double t0_s = 1.0) {
        const PacketFormat format(mode);
        const auto columns = static_cast<std::uint64_t>(mode.columns_per_frame);
        const std::uint64_t period_ns =
            1'000'000'000ull / static_cast<std::uint64_t>(mode.frames_per_second);
        const std::uint64_t step_ns = period_ns / columns;
        for (std::uint32_t f = first; f < first + count; ++f) {
            const std::uint64_t start = static_cast<std::uint64_t>(t0_s * 1e9) + f * period_ns;
            for (std::uint64_t c = 0; c < columns;
                 c += static_cast<std::uint64_t>(format.columns_per_packet())) {
                const auto p = packet(format, f, static_cast<int>(c), kSerial, start, step_ns);
                assembler.add_packet(p.data(), p.size());
            }
        }
    }
    ScanAssembler assembler;
    std::vector<Emitted> emitted;
};

// 1024x20 -> 512x20 -> 1024x20 on a sensor configured 1024x20: the half frames disagree
// at once (rejected), the sensor is flagged at the third, and trusted again after three
// good frames; the text says what was seen and what the metadata says.
TEST(ModeMismatch, ModeChangeIsFlaggedAfterThreeFramesDescribedAndClearedAfterThreeGoodOnes) {
    const SensorInfo configured = sensor(kRng19, 1024, kSerial, 7502);
    Rig rig(configured);
    rig.send(configured, 1, 4);
    ASSERT_EQ(rig.emitted.size(), 4u);
    for (const auto& e : rig.emitted) EXPECT_FALSE(e.rejected);

    rig.send(sensor(kRng19, 512, kSerial, 7502), 5, 6);
    rig.assembler.flush();
    ASSERT_EQ(rig.emitted.size(), 10u);
    for (std::size_t i = 4; i < 10; ++i) {
        EXPECT_TRUE(rig.emitted[i].rejected) << "frame " << i;
        EXPECT_EQ(rig.emitted[i].flagged, i >= 6) << "frame " << i;
    }
    const auto& check = rig.assembler.mode_check();
    EXPECT_TRUE(check.mismatch());
    EXPECT_EQ(check.mismatches(), 1u);
    EXPECT_EQ(check.frames_disagreeing(), 6u);
    EXPECT_EQ(rig.assembler.counters().mode_mismatch_frames, 6u);
    EXPECT_EQ(rig.assembler.counters().mode_mismatches, 1u);
    EXPECT_EQ(check.last_disagreement().evidence, ModeEvidence::kColumnSpacing);
    EXPECT_EQ(check.last_disagreement().last_column, 511u);
    const std::string text = ouster::describe(check.last_disagreement(), check.expected());
    EXPECT_NE(text.find("columns 0..511"), std::string::npos) << text;
    EXPECT_NE(text.find("97.7 us"), std::string::npos) << text;
    EXPECT_NE(text.find("(1024x20) says columns 0..1023, 48.8 us, 50.0 ms"), std::string::npos)
        << text;

    rig.send(configured, 11, 4);
    ASSERT_EQ(rig.emitted.size(), 14u);
    EXPECT_TRUE(rig.emitted[10].rejected);  // agrees, but the sensor is still flagged
    EXPECT_TRUE(rig.emitted[11].rejected);
    EXPECT_FALSE(rig.emitted[12].rejected);  // third agreeing frame clears the flag
    EXPECT_FALSE(rig.emitted[13].rejected);
    EXPECT_FALSE(check.mismatch());
    EXPECT_EQ(check.mismatches(), 1u);
}

// Every mode change between the OS1's modes is seen, by column spacing or, where the
// spacing is the same (2048x10 vs 1024x20, 512x20 vs 1024x10), by the frame period.
TEST(ModeMismatch, EveryOtherModeIsSeenByColumnSpacingOrFramePeriod) {
    struct Case {
        int configured_columns, configured_fps, sent_columns, sent_fps;
        ModeEvidence evidence;
    };
    for (const Case c : {Case{1024, 20, 512, 20, ModeEvidence::kColumnSpacing},
                         Case{1024, 20, 1024, 10, ModeEvidence::kColumnSpacing},
                         Case{512, 20, 1024, 20, ModeEvidence::kColumnSpacing},
                         Case{1024, 20, 2048, 10, ModeEvidence::kFramePeriod},
                         Case{1024, 10, 512, 20, ModeEvidence::kFramePeriod},
                         Case{512, 10, 2048, 10, ModeEvidence::kColumnSpacing}}) {
        SCOPED_TRACE(std::to_string(c.sent_columns) + "x" + std::to_string(c.sent_fps) + " sent, " +
                     std::to_string(c.configured_columns) + "x" + std::to_string(c.configured_fps) +
                     " configured");
        Rig rig(sensor(kRng19, c.configured_columns, kSerial, 7502, c.configured_fps));
        rig.send(sensor(kRng19, c.sent_columns, kSerial, 7502, c.sent_fps), 1, 6);
        rig.assembler.flush();
        ASSERT_GE(rig.emitted.size(), 5u);
        for (std::size_t i = 1; i < rig.emitted.size(); ++i)
            EXPECT_TRUE(rig.emitted[i].rejected) << i;
        EXPECT_TRUE(rig.assembler.mode_check().mismatch());
        EXPECT_EQ(rig.assembler.mode_check().last_disagreement().evidence, c.evidence);
        // The same mode as configured never disagrees.
        Rig same(sensor(kRng19, c.configured_columns, kSerial, 7502, c.configured_fps));
        same.send(sensor(kRng19, c.configured_columns, kSerial, 7502, c.configured_fps), 1, 6);
        EXPECT_EQ(same.assembler.mode_check().frames_disagreeing(), 0u);
    }
}

// A profile change makes every datagram the wrong size: after three frames' worth in a
// row the sensor is flagged (packet_size, both sizes in the text); correct packets clear it.
TEST(ModeMismatch, ProfileChangeIsFlaggedFromARunOfWrongSizeDatagrams) {
    const SensorInfo configured = sensor(kRng19, 1024, kSerial, 7502);
    Rig rig(configured);
    rig.send(configured, 1, 2);
    const PacketFormat legacy(sensor(ouster::UdpProfileLidar::kLegacy, 1024, 0, 7502));
    const auto wrong = packet(legacy, 3, 0, 0, 0, 48'828);
    for (int i = 0; i < 3 * 64 - 1; ++i) rig.assembler.add_packet(wrong.data(), wrong.size());
    EXPECT_FALSE(rig.assembler.mode_check().mismatch());
    rig.assembler.add_packet(wrong.data(), wrong.size());
    const auto& check = rig.assembler.mode_check();
    ASSERT_TRUE(check.mismatch());
    EXPECT_EQ(check.last_disagreement().evidence, ModeEvidence::kPacketSize);
    const std::string text = ouster::describe(check.last_disagreement(), check.expected());
    EXPECT_NE(text.find("192 datagrams in a row of " + std::to_string(legacy.lidar_packet_size()) +
                        " bytes"),
              std::string::npos)
        << text;
    EXPECT_NE(text.find("lidar packets of " +
                        std::to_string(PacketFormat(configured).lidar_packet_size())),
              std::string::npos)
        << text;
    EXPECT_EQ(rig.assembler.counters().bad_size, 192u);
    // Back to the configured profile: flagged for two more frames, then trusted.
    rig.send(configured, 10, 4);
    EXPECT_FALSE(check.mismatch());
    EXPECT_EQ(check.mismatches(), 1u);
    ASSERT_EQ(rig.emitted.size(), 6u);
    EXPECT_TRUE(rig.emitted[2].rejected && rig.emitted[3].rejected);
    EXPECT_FALSE(rig.emitted[4].rejected);
    // Wrong-size datagrams between good packets (a foreign device on the port) are no run.
    const auto good = packet(PacketFormat(configured), 20, 0, kSerial, 2'000'000'000, 48'828);
    for (int i = 0; i < 1000; ++i) {
        rig.assembler.add_packet(wrong.data(), wrong.size());
        if (i % 50 == 0) rig.assembler.add_packet(good.data(), good.size());
    }
    EXPECT_FALSE(check.mismatch());
}

// Not a mode change: 10 % of packets lost and the rest shuffled inside each frame, an
// azimuth window, a sensor clock jump inside one frame, a restart. Never flagged.
TEST(ModeMismatch, LossReorderWindowsClockJumpsAndRestartsAreNotAModeChange) {
    SensorInfo windowed = sensor(kRng19, 1024, kSerial, 7502);
    windowed.column_window = {200, 700};
    for (const SensorInfo& info : {sensor(kRng19, 1024, kSerial, 7502), windowed}) {
        Rig rig(info);
        const PacketFormat format(info);
        std::mt19937 rng(11);
        for (std::uint32_t f = 1; f <= 40; ++f) {
            std::uint64_t start = 1'000'000'000ull + f * 50'000'000ull;
            if (f >= 20) start += 37'000'000'000ull;  // the 37 s TAI jump, from frame 20 on
            std::vector<int> firsts;
            for (int c = 0; c < 1024; c += 16) {
                if (c + 15 < info.column_window[0] || c > info.column_window[1]) {
                    continue;
                }
                if (rng() % 10 != 0) firsts.push_back(c);
            }
            std::shuffle(firsts.begin(), firsts.end(), rng);
            for (int c : firsts) {
                // Frame 30 jumps back 2 s in its middle.
                const std::uint64_t t = f == 30 && c >= 512 ? start - 2'000'000'000ull : start;
                const auto p =
                    packet(format, f == 35 ? 1 : f, c, kSerial, t, 48'828);  // 35: restart
                rig.assembler.add_packet(p.data(), p.size());
            }
        }
        rig.assembler.flush();
        EXPECT_GE(rig.emitted.size(), 38u);
        EXPECT_EQ(rig.assembler.mode_check().mismatches(), 0u);
        EXPECT_LE(rig.assembler.mode_check().frames_disagreeing(), 3u);
        for (const auto& e : rig.emitted) EXPECT_FALSE(e.flagged);
    }
}

// Every sample capture from real sensors (several firmware versions, modes and
// profiles): not one frame disagrees with its metadata.
TEST(ModeMismatch, RealSampleCapturesNeverDisagreeWithTheirMetadata) {
    const std::vector<std::pair<std::string, std::vector<std::string>>> captures = {
        {"OS-0-128-U1_v2.3.0_1024x10.pcap", {"OS-0-128-U1_v2.3.0_1024x10.json"}},
        {"OS-0-32-U1_v2.2.0_1024x10.pcap", {"OS-0-32-U1_v2.2.0_1024x10.json"}},
        {"OS-1-32-G_v2.1.1_1024x10.pcap", {"OS-1-32-G_v2.1.1_1024x10.json"}},
        {"OS-2-128-U1_v2.3.0_1024x10.pcap", {"OS-2-128-U1_v2.3.0_1024x10.json"}},
        {"OS-1-64_1024x10_fw20.pcap", {"OS-1-64_sensor_config_reduced.json"}},
        {"crc_test.pcap", {"crc_test.json"}},
        {"duplicate_id.pcap", {"duplicate_id.json"}},
        {"same_ports.pcap", {"same_ports.1.json", "same_ports.2.json"}},
        {"same_ports_legacy.pcap", {"same_ports_legacy.1.json", "same_ports_legacy.2.json"}},
        {"same_ports_nonlegacy.pcap",
         {"same_ports_nonlegacy.1.json", "same_ports_nonlegacy.2.json"}},
    };
    for (const auto& [pcap_name, metas] : captures) {
        SCOPED_TRACE(pcap_name);
        LIDARFUSE_REQUIRE_OUSTER_FILE(pcap_file, pcap_name);
        std::vector<SensorInfo> infos;
        std::vector<ouster::RoutedSensor> routed;
        for (const auto& m : metas) {
            infos.push_back(ouster::load_metadata(*test::ouster_file(m)));
            routed.push_back({infos.back(), std::nullopt});
        }
        ouster::SensorRouter router(routed);
        std::vector<std::unique_ptr<ScanAssembler>> assemblers;
        std::size_t frames = 0;
        for (const auto& info : infos) {
            assemblers.push_back(std::make_unique<ScanAssembler>(
                info, ouster::ScanAssemblerParams{}, [&](const ouster::LidarScan&) { ++frames; }));
        }
        pcap::PcapReader reader(pcap_file);
        pcap::UdpDatagram d;
        while (reader.next(&d)) {
            const int i = router.route(d.src_ip, d.dst_port, d.data, d.size);
            if (i != ouster::SensorRouter::kUnassigned)
                assemblers[static_cast<std::size_t>(i)]->add_packet(d.data, d.size);
        }
        for (std::size_t i = 0; i < assemblers.size(); ++i) {
            assemblers[i]->flush();
            const auto& check = assemblers[i]->mode_check();
            EXPECT_EQ(check.frames_disagreeing(), 0u)
                << metas[i] << ": "
                << ouster::describe(check.last_disagreement(), check.expected());
            EXPECT_FALSE(check.mismatch()) << metas[i];
        }
        EXPECT_GT(frames, 0u);
    }
}

}  // namespace
}  // namespace lidarfuse::reliability

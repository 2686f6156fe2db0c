// Golden tests on Ouster's sample captures (../shared/data/ouster, SOURCES.md): the pcap
// reader, sensor router and scan assembler must rebuild exactly the frames Ouster's SDK
// built, byte for byte in the digest convention, and the documented per-capture facts.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/sensor_router.hpp"
#include "drivers/ouster/xyz_lut.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::ouster {
namespace {

struct Assembled {
    LidarScan scan;                          // a copy of the emitted frame
    std::map<std::string, std::string> md5;  // digest name -> md5
};

struct SensorResult {
    SensorInfo info;
    std::vector<Assembled> frames;
    AssemblyCounters counters;
};

// Runs the capture through router + one assembler per metadata file, then flushes.
std::vector<SensorResult> assemble(const std::filesystem::path& pcap,
                                   const std::vector<std::filesystem::path>& metas) {
    std::vector<RoutedSensor> routed;
    std::vector<SensorResult> out(metas.size());
    for (std::size_t i = 0; i < metas.size(); ++i) {
        out[i].info = load_metadata(metas[i]);
        routed.push_back({out[i].info, std::nullopt});
    }
    SensorRouter router(routed);
    std::vector<std::unique_ptr<ScanAssembler>> assemblers;
    for (std::size_t i = 0; i < metas.size(); ++i) {
        auto* frames = &out[i].frames;
        assemblers.push_back(std::make_unique<ScanAssembler>(
            out[i].info, ScanAssemblerParams{}, [frames](const LidarScan& s) {
                Assembled a{s, {}};
                for (const auto& arr : digest_arrays(s)) {
                    a.md5[arr.name] = test::md5_hex(arr.data, arr.bytes);
                }
                frames->push_back(std::move(a));
            }));
    }
    pcap::PcapReader reader(pcap);
    pcap::UdpDatagram d;
    while (reader.next(&d)) {
        const int i = router.route(d.src_ip, d.dst_port, d.data, d.size);
        if (i != SensorRouter::kUnassigned)
            assemblers[static_cast<std::size_t>(i)]->add_packet(d.data, d.size);
    }
    for (std::size_t i = 0; i < metas.size(); ++i) {
        assemblers[i]->flush();
        out[i].counters = assemblers[i]->counters();
    }
    return out;
}

nlohmann::json read_json(const std::filesystem::path& file) {
    std::ifstream in(file);
    return nlohmann::json::parse(in);
}

// Compares every frame hash of a digest entry list (`scans` or the DERIVED `frames`).
void expect_frames_match(const std::vector<Assembled>& frames, const nlohmann::json& entries) {
    ASSERT_EQ(frames.size(), entries.size());
    for (std::size_t k = 0; k < frames.size(); ++k) {
        const auto& entry = entries[k];
        const Assembled& got = frames[k];
        EXPECT_EQ(std::to_string(got.scan.frame_id), entry.at("FRAME_ID").get<std::string>());
        std::set<std::string> expected_keys;
        for (const auto& [key, value] : entry.items()) {
            // ENCODER_COUNT: no longer compared by the SDK itself (SOURCES.md).
            if (key == "FRAME_ID" || key == "ENCODER_COUNT") continue;
            expected_keys.insert(key);
            ASSERT_TRUE(got.md5.count(key)) << "frame " << got.scan.frame_id << " lacks " << key;
            EXPECT_EQ(got.md5.at(key), value.get<std::string>())
                << "frame " << got.scan.frame_id << " field " << key;
        }
        std::set<std::string> got_keys;
        for (const auto& [key, value] : got.md5) got_keys.insert(key);
        EXPECT_EQ(got_keys, expected_keys) << "fields of frame " << got.scan.frame_id;
    }
}

struct DigestCase {
    const char* capture;
};

class DigestFile : public ::testing::TestWithParam<DigestCase> {};

TEST_P(DigestFile, EveryFrameMatchesOustersHashes) {
    const std::string base = GetParam().capture;
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, base + ".pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, base + ".json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(digest, base + "_digest.json");
    const auto result = assemble(pcap, {meta});
    const auto json = read_json(digest);
    expect_frames_match(result[0].frames, json.at("scans"));
    for (const auto& f : result[0].frames) EXPECT_TRUE(f.scan.complete()) << f.scan.frame_id;
    const auto& c = result[0].counters;
    EXPECT_EQ(c.lidar_packets, 64u);
    EXPECT_EQ(c.bad_size + c.bad_profile + c.crc_errors + c.late_packets + c.duplicate_packets, 0u);
    EXPECT_EQ(c.missing_columns, 0u);
}

INSTANTIATE_TEST_SUITE_P(Captures, DigestFile,
                         ::testing::Values(DigestCase{"OS-2-128-U1_v2.3.0_1024x10"},
                                           DigestCase{"OS-0-128-U1_v2.3.0_1024x10"},
                                           DigestCase{"OS-1-32-G_v2.1.1_1024x10"},
                                           DigestCase{"OS-0-32-U1_v2.2.0_1024x10"}));

TEST(Golden, DigestCasesCoverEveryDigestFileInTheDataFolder) {
    const auto dir = test::data_dir();
    if (!dir) GTEST_SKIP() << "sample data not found (set LIDARFUSE_DATA_DIR)";
    std::set<std::string> covered = {"OS-2-128-U1_v2.3.0_1024x10", "OS-0-128-U1_v2.3.0_1024x10",
                                     "OS-1-32-G_v2.1.1_1024x10", "OS-0-32-U1_v2.2.0_1024x10"};
    const std::string suffix = "_digest.json";
    for (const auto& e : std::filesystem::directory_iterator(*dir / "ouster")) {
        const std::string name = e.path().filename().string();
        if (name.size() > suffix.size() &&
            name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
            EXPECT_TRUE(covered.count(name.substr(0, name.size() - suffix.size()))) << name;
        }
    }
}

TEST(Golden, LegacyFw20ReducedMetadataGivesFrame189AsDerived) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "OS-1-64_1024x10_fw20.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, "OS-1-64_sensor_config_reduced.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(ref, "DERIVED_OS-1-64_1024x10_fw20_reference.json");
    const auto result = assemble(pcap, {meta});
    const auto json = read_json(ref);
    ASSERT_EQ(result[0].frames.size(), 1u);
    expect_frames_match(result[0].frames, json.at("frames"));
    const LidarScan& s = result[0].frames[0].scan;
    EXPECT_EQ(s.frame_id, 189u);
    EXPECT_TRUE(s.complete());
    EXPECT_EQ(result[0].counters.imu_packets, 11u);
    const auto& summary = json.at("frame_summary");
    EXPECT_EQ(s.packets, summary.at("lidar_packets").get<std::uint32_t>());
    EXPECT_EQ(s.timestamp_ns.front(), summary.at("first_col_timestamp_ns").get<std::uint64_t>());
    EXPECT_EQ(s.timestamp_ns.back(), summary.at("last_col_timestamp_ns").get<std::uint64_t>());

    ScanCloud cloud;
    const XyzLut lut = make_xyz_lut(result[0].info);
    ASSERT_TRUE(project_scan(s, lut, {}, &cloud));
    EXPECT_EQ(cloud.cloud.size(), summary.at("nonzero_range_pixels").get<std::size_t>());
    for (const auto& px : json.at("sample_pixels")) {
        const int row = px.at("row").get<int>();
        const int col = px.at("col").get<int>();
        const std::size_t i = static_cast<std::size_t>(row) * s.columns() + col;
        EXPECT_EQ(s.range_mm[i], px.at("range_mm").get<std::uint32_t>()) << row << "," << col;
        EXPECT_EQ(s.signal[i], px.at("signal").get<std::uint16_t>());
        EXPECT_EQ(s.near_ir[i], px.at("near_ir").get<std::uint16_t>());
        EXPECT_EQ(s.reflectivity[i], px.at("reflectivity").get<std::uint8_t>());
        const auto xyz = px.at("xyz_sensor_m");
        const Eigen::Vector3d expected(xyz[0].get<double>(), xyz[1].get<double>(),
                                       xyz[2].get<double>());
        // The reference is printed with 6 decimals.
        EXPECT_LT((lut.point(row, col, s.range_mm[i]) - expected).norm(), 2e-6)
            << "pixel " << row << "," << col;
    }
}

struct SamePortsCase {
    const char* capture;
    std::uint32_t frame_id_1;  // sensor of <capture>.1.json (OS-0-128, h = 128)
    std::uint32_t frame_id_2;  // sensor of <capture>.2.json (OS-1-64-AH, h = 64)
};

class SamePorts : public ::testing::TestWithParam<SamePortsCase> {};

TEST_P(SamePorts, EachSensorGetsItsOwnFrame) {
    const std::string base = GetParam().capture;
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, base + ".pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta1, base + ".1.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta2, base + ".2.json");
    const auto result = assemble(pcap, {meta1, meta2});
    ASSERT_EQ(result[0].frames.size(), 1u);
    ASSERT_EQ(result[1].frames.size(), 1u);
    EXPECT_EQ(result[0].frames[0].scan.frame_id, GetParam().frame_id_1);
    EXPECT_EQ(result[0].frames[0].scan.rows(), 128u);
    EXPECT_EQ(result[1].frames[0].scan.frame_id, GetParam().frame_id_2);
    EXPECT_EQ(result[1].frames[0].scan.rows(), 64u);
    for (const auto& r : result) {
        EXPECT_EQ(r.counters.lidar_packets, 1u);
        EXPECT_EQ(r.counters.bad_size + r.counters.bad_profile + r.counters.crc_errors, 0u);
        EXPECT_EQ(r.frames[0].scan.packets, 1u);
    }
}

// Frame ids: same_ports and same_ports_legacy as documented (SOURCES.md, upstream tests);
// same_ports_nonlegacy read from the packet headers (STANDARD u16 @2, FUSA u32 @4).
INSTANTIATE_TEST_SUITE_P(Captures, SamePorts,
                         ::testing::Values(SamePortsCase{"same_ports", 1542, 883},
                                           SamePortsCase{"same_ports_legacy", 457, 185},
                                           SamePortsCase{"same_ports_nonlegacy", 1093, 1535}));

TEST(Golden, SamePortsNonLegacyStandardPacketHasAValidCrc) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "same_ports_nonlegacy.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta1, "same_ports_nonlegacy.1.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta2, "same_ports_nonlegacy.2.json");
    const auto result = assemble(pcap, {meta1, meta2});
    EXPECT_EQ(result[1].counters.crc_valid, 1u);
    EXPECT_EQ(result[0].counters.imu_packets + result[1].counters.imu_packets, 1u)
        << "the IMU packet after its sensor's lidar packet is routed by source address";
}

TEST(Golden, DuplicateIdReassemblesExactlyOneFrame1778) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "duplicate_id.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, "duplicate_id.json");
    const auto result = assemble(pcap, {meta});
    ASSERT_EQ(result[0].frames.size(), 1u);
    EXPECT_EQ(result[0].frames[0].scan.frame_id, 1778u);
    EXPECT_EQ(result[0].counters.lidar_packets, 1u);
    EXPECT_EQ(result[0].counters.bad_size, 0u);
}

// Columns [first, last] of `s` were received with status 0 and zero range.
void expect_invalid_columns(const LidarScan& s, std::uint32_t first, std::uint32_t last) {
    for (std::uint32_t c = first; c <= last; ++c) {
        EXPECT_EQ(s.received[c], 1) << c;
        EXPECT_EQ(s.status[c], 0u) << c;
        for (std::size_t r = 0; r < s.rows(); ++r) ASSERT_EQ(s.range_mm[r * s.columns() + c], 0u);
    }
}

TEST(Golden, WindowedFrame1IsCompleteWithoutLoss) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "windowed_frame1.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, "windowed_frame1_0.json");
    const auto result = assemble(pcap, {meta});
    ASSERT_EQ(result[0].frames.size(), 1u);
    const LidarScan& s = result[0].frames[0].scan;
    EXPECT_EQ(s.frame_id, 1553u);
    EXPECT_TRUE(s.complete());
    EXPECT_EQ(s.expected_columns(), 256u);
    EXPECT_EQ(s.packets, 17u);
    EXPECT_EQ(result[0].counters.missing_columns, 0u);
    EXPECT_EQ(result[0].counters.frames_incomplete, 0u);
    expect_invalid_columns(s, 0, 0);
    expect_invalid_columns(s, 257, 271);
    for (std::uint32_t c = 1; c <= 256; ++c) EXPECT_EQ(s.status[c] & 1u, 1u) << c;
    for (std::uint32_t c = 272; c < 512; ++c) EXPECT_EQ(s.received[c], 0) << c;
}

TEST(Golden, WindowedFrame2WrapsThroughZeroWithoutLoss) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "windowed_frame2.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, "windowed_frame2_0.json");
    const auto result = assemble(pcap, {meta});
    ASSERT_EQ(result[0].frames.size(), 1u);
    const LidarScan& s = result[0].frames[0].scan;
    EXPECT_EQ(s.frame_id, 1314u);
    EXPECT_TRUE(s.complete());
    EXPECT_EQ(s.column_window().first, 370u);
    EXPECT_EQ(s.column_window().last, 85u);
    EXPECT_EQ(s.packets, 15u);
    EXPECT_EQ(result[0].counters.missing_columns, 0u);
    expect_invalid_columns(s, 86, 95);
    expect_invalid_columns(s, 368, 369);
    for (std::uint32_t c = 96; c < 368; ++c) EXPECT_EQ(s.received[c], 0) << c;
    for (std::uint32_t c = 370; c < 512; ++c) EXPECT_EQ(s.status[c] & 1u, 1u) << c;
    for (std::uint32_t c = 0; c <= 85; ++c) EXPECT_EQ(s.status[c] & 1u, 1u) << c;
}

TEST(Golden, CrcTestHasCompleteFrame254AndPartial255WithValidCrcs) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "crc_test.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, "crc_test.json");
    const auto result = assemble(pcap, {meta});
    ASSERT_EQ(result[0].frames.size(), 2u);
    EXPECT_EQ(result[0].frames[0].scan.frame_id, 254u);
    EXPECT_TRUE(result[0].frames[0].scan.complete());
    EXPECT_EQ(result[0].frames[0].scan.packets, 32u);
    EXPECT_EQ(result[0].frames[1].scan.frame_id, 255u);
    EXPECT_FALSE(result[0].frames[1].scan.complete());
    EXPECT_EQ(result[0].frames[1].scan.packets, 2u);
    EXPECT_EQ(result[0].counters.crc_valid, 34u);
    EXPECT_EQ(result[0].counters.crc_errors, 0u);
    EXPECT_EQ(result[0].counters.imu_packets, 10u);
}

}  // namespace
}  // namespace lidarfuse::ouster

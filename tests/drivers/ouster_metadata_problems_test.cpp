// Ouster metadata: broken documents list every problem with its JSON path, and no random
// mutation of a real file crashes the parser. Sample files and defaults:
// ouster_metadata_test.cpp.

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "drivers/ouster/metadata.hpp"
#include "tests/drivers/ouster_metadata_test_support.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::ouster {
namespace {

using metadata_test::Expected;
using metadata_test::has_problem;
using metadata_test::joined;
using metadata_test::kSamples;
using nlohmann::json;

std::string read_text(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// Parses `text` expecting a MetadataError; returns its problems.
std::vector<std::string> problems_of(const std::string& text) {
    try {
        parse_metadata(text, "test.json");
    } catch (const MetadataError& e) {
        EXPECT_NE(std::string(e.what()).find("test.json"), std::string::npos) << e.what();
        return e.problems();
    }
    ADD_FAILURE() << "expected a MetadataError";
    return {};
}

json sample_nested() {
    const auto path = test::ouster_file("same_ports_nonlegacy.2.json");
    return path ? json::parse(read_text(*path)) : json();
}

TEST(OusterMetadata, MalformedJsonIsAClearError) {
    const auto p1 = problems_of("{\"beam_altitude_angles\": [1, 2,");
    ASSERT_EQ(p1.size(), 1u);
    EXPECT_NE(p1[0].find("malformed JSON"), std::string::npos) << p1[0];
    EXPECT_TRUE(has_problem(problems_of(""), "malformed JSON"));
    EXPECT_TRUE(has_problem(problems_of("[1, 2, 3]"), "expected a JSON object"));
    EXPECT_TRUE(has_problem(problems_of("{}"), "lidar_mode: missing"));
}

TEST(OusterMetadata, LoadNamesTheFile) {
    test::TempDir dir("ouster_meta");
    const auto missing = dir.path() / "nope.json";
    try {
        load_metadata(missing);
        FAIL() << "expected an error";
    } catch (const MetadataError& e) {
        EXPECT_NE(std::string(e.what()).find("nope.json"), std::string::npos);
    }
    const auto broken = dir.path() / "broken.json";
    std::ofstream(broken) << "{ \"lidar_mode\": \"1024x10\", ";
    try {
        load_metadata(broken);
        FAIL() << "expected an error";
    } catch (const MetadataError& e) {
        EXPECT_NE(std::string(e.what()).find("broken.json"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("malformed JSON"), std::string::npos) << e.what();
    }
}

TEST(OusterMetadata, TruncatedRealFileFailsCleanly) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(path, "crc_test.json");
    const std::string text = read_text(path);
    for (std::size_t cut : {std::size_t{1}, text.size() / 3, text.size() / 2, text.size() - 2}) {
        EXPECT_FALSE(problems_of(text.substr(0, cut)).empty()) << cut;
    }
}

TEST(OusterMetadata, EveryProblemIsListedWithItsPath) {
    json doc = sample_nested();
    if (doc.is_null()) GTEST_SKIP() << "sample data not found";
    doc["beam_intrinsics"]["beam_altitude_angles"].erase(0);                        // 63 of 64
    doc["lidar_data_format"]["columns_per_frame"] = 2048;                           // vs 1024x10
    doc["config_params"]["udp_port_lidar"] = "abc";                                 // type
    doc["lidar_data_format"]["udp_profile_lidar"] = "RNG99";                        // unknown
    doc["beam_intrinsics"]["beam_azimuth_angles"][5] = "x";                         // element type
    doc["lidar_intrinsics"]["lidar_to_sensor_transform"] = json::array({1, 2, 3});  // size
    const auto problems = problems_of(doc.dump());
    EXPECT_TRUE(
        has_problem(problems, "beam_intrinsics.beam_altitude_angles: expected 64 numbers, got 63"))
        << joined(problems);
    EXPECT_TRUE(has_problem(problems, "lidar_data_format.columns_per_frame: 2048 contradicts"))
        << joined(problems);
    EXPECT_TRUE(has_problem(problems, "config_params.udp_port_lidar: expected an integer"))
        << joined(problems);
    EXPECT_TRUE(has_problem(
        problems, "lidar_data_format.udp_profile_lidar: unknown UDP lidar profile \"RNG99\""))
        << joined(problems);
    EXPECT_TRUE(
        has_problem(problems, "beam_intrinsics.beam_azimuth_angles[5]: expected a finite number"))
        << joined(problems);
    EXPECT_TRUE(
        has_problem(problems, "lidar_intrinsics.lidar_to_sensor_transform: expected 16 numbers"))
        << joined(problems);
    EXPECT_EQ(problems.size(), 6u) << joined(problems);
}

TEST(OusterMetadata, ContradictoryKeysAreReported) {
    json doc = sample_nested();
    if (doc.is_null()) GTEST_SKIP() << "sample data not found";
    doc["config_params"]["udp_profile_lidar"] = "RNG15_RFL8_NIR8";
    doc["config_params"]["columns_per_packet"] = 8;
    doc["beam_intrinsics"]["lidar_origin_to_beam_origin_mm"] = 20.0;
    doc["lidar_data_format"]["fps"] = 20;
    doc["lidar_data_format"]["pixel_shift_by_row"].push_back(3);
    doc["lidar_data_format"]["column_window"] = json::array({0, 1024});
    const auto problems = problems_of(doc.dump());
    EXPECT_TRUE(has_problem(
        problems, "lidar_data_format.udp_profile_lidar: RNG19_RFL8_SIG16_NIR16_DUAL contradicts"))
        << joined(problems);
    EXPECT_TRUE(has_problem(problems, "lidar_data_format.columns_per_packet: 16 contradicts"))
        << joined(problems);
    EXPECT_TRUE(has_problem(problems, "beam_intrinsics.beam_to_lidar_transform: translation gives"))
        << joined(problems);
    EXPECT_TRUE(has_problem(problems, "lidar_data_format.fps: 20 contradicts")) << joined(problems);
    EXPECT_TRUE(
        has_problem(problems, "lidar_data_format.pixel_shift_by_row: expected 64 integers, got 65"))
        << joined(problems);
    EXPECT_TRUE(has_problem(problems, "lidar_data_format.column_window[1]: 1024 outside 0..1023"))
        << joined(problems);
}

TEST(OusterMetadata, MissingKeysAreReported) {
    json doc = sample_nested();
    if (doc.is_null()) GTEST_SKIP() << "sample data not found";
    doc.erase("sensor_info");
    doc["beam_intrinsics"].erase("beam_azimuth_angles");
    doc["config_params"].erase("lidar_mode");
    doc["lidar_data_format"].erase("columns_per_frame");
    const auto problems = problems_of(doc.dump());
    EXPECT_TRUE(has_problem(problems, "sensor_info: missing")) << joined(problems);
    EXPECT_TRUE(has_problem(problems, "beam_intrinsics.beam_azimuth_angles: missing"))
        << joined(problems);
    EXPECT_TRUE(has_problem(problems, "config_params.lidar_mode: missing")) << joined(problems);
}

TEST(OusterMetadata, NonRigidTransformIsRejected) {
    json doc = sample_nested();
    if (doc.is_null()) GTEST_SKIP() << "sample data not found";
    doc["lidar_intrinsics"]["lidar_to_sensor_transform"][0] = 2.0;
    doc["imu_intrinsics"]["imu_to_sensor_transform"][15] = 0.0;
    const auto problems = problems_of(doc.dump());
    EXPECT_TRUE(has_problem(problems, "lidar_intrinsics.lidar_to_sensor_transform: rotation part"))
        << joined(problems);
    EXPECT_TRUE(has_problem(problems, "imu_intrinsics.imu_to_sensor_transform: last row"))
        << joined(problems);
}

TEST(OusterMetadata, ValidateSensorInfoBuiltInCode) {
    SensorInfo info;
    EXPECT_TRUE(has_problem(validate_sensor_info(info),
                            "beam_altitude_angles_deg: expected 64 numbers, got 0"));
    info.beam_altitude_angles_deg.assign(64, 1.0);
    info.beam_azimuth_angles_deg.assign(64, 0.5);
    info.pixel_shift_by_row.assign(64, 0);
    info.lidar_to_sensor_transform = default_lidar_to_sensor_transform();
    EXPECT_TRUE(validate_sensor_info(info).empty()) << joined(validate_sensor_info(info));
    info.columns_per_packet = 24;  // does not divide 1024
    info.lidar_mode = "2048x10";   // contradicts columns_per_frame 1024
    const auto problems = validate_sensor_info(info);
    EXPECT_TRUE(has_problem(problems, "columns_per_packet: 24 does not divide"))
        << joined(problems);
    EXPECT_TRUE(has_problem(problems, "columns_per_frame: 1024 x 10 Hz contradicts"))
        << joined(problems);
}

// --- randomised corpus ---

// Seeded byte-level and structural mutations of every sample: parse either succeeds or
// throws MetadataError (never another exception, never a crash under ASan).
TEST(OusterMetadata, RandomMutationsNeverCrash) {
    std::vector<std::string> corpus;
    for (const Expected& e : kSamples) {
        if (const auto path = test::ouster_file(e.file)) corpus.push_back(read_text(*path));
    }
    if (corpus.empty()) GTEST_SKIP() << "sample data not found";
    std::mt19937_64 rng(20261121);
    static const json kWeird[] = {
        json(),         json(-1),   json(1e308),        json("x"), json::array(),
        json::object(), json(true), json(4294967296LL), json(0.5), json::array({1, "a"})};
    int parsed = 0;
    int rejected = 0;
    for (int iter = 0; iter < 3000; ++iter) {
        std::string text = corpus[rng() % corpus.size()];
        const int kind = static_cast<int>(rng() % 4);
        if (kind == 0) {  // flip bytes
            for (int k = 0; k < 1 + static_cast<int>(rng() % 8); ++k) {
                text[rng() % text.size()] = static_cast<char>(rng() % 256);
            }
        } else if (kind == 1) {  // truncate
            text.resize(rng() % text.size());
        } else {  // structural: replace or delete a random value somewhere in the tree
            json doc = json::parse(text);
            json* node = &doc;
            for (int depth = 0;
                 depth < 3 && (node->is_object() || node->is_array()) && !node->empty(); ++depth) {
                auto it = node->begin();
                std::advance(it, static_cast<long>(rng() % node->size()));
                node = &*it;
            }
            if (kind == 2) {
                *node = kWeird[rng() % std::size(kWeird)];
            } else if (doc.is_object() && !doc.empty()) {
                auto it = doc.begin();
                std::advance(it, static_cast<long>(rng() % doc.size()));
                doc.erase(it.key());
            }
            text = doc.dump();
        }
        try {
            const SensorInfo info = parse_metadata(text, "mutant");
            ++parsed;
            (void)to_nested_json(info);
        } catch (const MetadataError& e) {
            ++rejected;
            EXPECT_FALSE(e.problems().empty());
        }
    }
    EXPECT_GT(rejected, 100);
    EXPECT_GT(parsed, 10);
}

}  // namespace
}  // namespace lidarfuse::ouster

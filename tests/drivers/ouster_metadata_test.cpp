// Ouster metadata: every sample file parses to the documented values, defaults apply to
// old files, broken documents list every problem with its JSON path, nothing crashes.

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "drivers/ouster/metadata.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::ouster {
namespace {

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

bool has_problem(const std::vector<std::string>& problems, const std::string& needle) {
    for (const auto& p : problems) {
        if (p.find(needle) != std::string::npos) return true;
    }
    return false;
}

std::string joined(const std::vector<std::string>& problems) {
    std::string s;
    for (const auto& p : problems) s += p + "\n";
    return s;
}

struct Expected {
    const char* file;
    const char* serial;
    MetadataForm form;
    const char* mode;
    int columns;
    UdpProfileLidar profile;
    int rows;
    int port_lidar;
    int port_imu;
    std::array<int, 2> window;
    std::uint32_t init_id;
    double beam_origin_mm;
};

const Expected kSamples[] = {
    {"OS-0-128-U1_v2.3.0_1024x10.json",
     "122150000150",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     7502,
     7503,
     {0, 1023},
     5431292,
     27.67},
    {"OS-0-32-U1_v2.2.0_1024x10.json",
     "992137000142",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
     32,
     7502,
     7503,
     {0, 1023},
     9599938,
     27.67},
    {"OS-1-32-G_v2.1.1_1024x10.json",
     "992101000280",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     32,
     7502,
     7503,
     {0, 1023},
     0,
     15.806},
    {"OS-1-64_sensor_config_reduced.json",
     "",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     64,
     7502,
     7503,
     {0, 1023},
     0,
     12.163},
    {"OS-2-128-U1_v2.3.0_1024x10.json",
     "992210000957",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kRng19Rfl8Sig16Nir16,
     128,
     7502,
     7503,
     {0, 1023},
     5431293,
     13.762},
    {"crc_test.json",
     "122247000785",
     MetadataForm::kNested,
     "512x10",
     512,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     7502,
     7503,
     {0, 511},
     11394290,
     27.116},
    {"duplicate_id.json",
     "992219000042",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     34636,
     48887,
     {0, 1023},
     8247312,
     13.762},
    {"same_ports.1.json",
     "122247000785",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kFusaRng15Rfl8Nir8Dual,
     128,
     7502,
     7502,
     {912, 1022},
     390073,
     27.116},
    {"same_ports.2.json",
     "122239000672",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     64,
     7502,
     7502,
     {912, 1022},
     16413612,
     15.806},
    {"same_ports_legacy.1.json",
     "122247000785",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     128,
     7502,
     7502,
     {0, 1023},
     15278603,
     27.116},
    {"same_ports_legacy.2.json",
     "122239000672",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     64,
     7502,
     7502,
     {0, 1023},
     9342168,
     15.806},
    {"same_ports_nonlegacy.1.json",
     "122247000785",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kFusaRng15Rfl8Nir8Dual,
     128,
     7502,
     7502,
     {0, 1023},
     390078,
     27.116},
    {"same_ports_nonlegacy.2.json",
     "122239000672",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
     64,
     7502,
     7502,
     {0, 1023},
     9342165,
     15.806},
    {"windowed_frame1_0.json",
     "992108000265",
     MetadataForm::kNested,
     "512x10",
     512,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     53750,
     7503,
     {1, 256},
     7109746,
     27.67},
    {"windowed_frame2_0.json",
     "992108000265",
     MetadataForm::kNested,
     "512x10",
     512,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     53750,
     7503,
     {370, 85},
     7109747,
     27.67},
};

class SampleMetadata : public ::testing::TestWithParam<Expected> {};

TEST_P(SampleMetadata, ParsesWithExpectedValues) {
    const Expected& e = GetParam();
    LIDARFUSE_REQUIRE_OUSTER_FILE(path, e.file);
    const SensorInfo info = load_metadata(path);
    EXPECT_EQ(info.prod_sn, e.serial);
    EXPECT_EQ(info.form, e.form);
    EXPECT_EQ(info.lidar_mode, e.mode);
    EXPECT_EQ(info.columns_per_frame, e.columns);
    EXPECT_EQ(info.frames_per_second, 10);
    EXPECT_EQ(info.udp_profile_lidar, e.profile) << to_string(info.udp_profile_lidar);
    EXPECT_EQ(info.pixels_per_column, e.rows);
    EXPECT_EQ(info.columns_per_packet, 16);
    EXPECT_EQ(info.udp_port_lidar, e.port_lidar);
    EXPECT_EQ(info.udp_port_imu, e.port_imu);
    EXPECT_EQ(info.column_window, e.window);
    EXPECT_EQ(info.init_id, e.init_id);
    EXPECT_DOUBLE_EQ(info.lidar_origin_to_beam_origin_mm, e.beam_origin_mm);
    EXPECT_EQ(info.beam_altitude_angles_deg.size(), static_cast<std::size_t>(e.rows));
    EXPECT_EQ(info.beam_azimuth_angles_deg.size(), static_cast<std::size_t>(e.rows));
    EXPECT_EQ(info.pixel_shift_by_row.size(), static_cast<std::size_t>(e.rows));
    // Every sample's beam origin sits on the x axis of the beam_to_lidar transform.
    EXPECT_NEAR(info.beam_to_lidar_transform(0, 3), e.beam_origin_mm, 1e-9);
    EXPECT_EQ(info.lidar_to_sensor_transform(0, 0), -1.0);
    EXPECT_EQ(info.lidar_to_sensor_transform(1, 1), -1.0);
    if (!std::string(e.serial).empty()) {
        EXPECT_EQ(info.serial_number(), std::stoull(e.serial));
    }
    EXPECT_TRUE(validate_sensor_info(info).empty()) << joined(validate_sensor_info(info));
}

TEST_P(SampleMetadata, NestedJsonRoundTrips) {
    const Expected& e = GetParam();
    LIDARFUSE_REQUIRE_OUSTER_FILE(path, e.file);
    const SensorInfo a = load_metadata(path);
    const std::string text = to_nested_json(a);
    const SensorInfo b = parse_metadata(text, "round trip");
    EXPECT_EQ(b.form, MetadataForm::kNested);
    EXPECT_EQ(b.prod_sn, a.prod_sn);
    EXPECT_EQ(b.prod_line, a.prod_line);
    EXPECT_EQ(b.prod_pn, a.prod_pn);
    EXPECT_EQ(b.build_rev, a.build_rev);
    EXPECT_EQ(b.image_rev, a.image_rev);
    EXPECT_EQ(b.status, a.status);
    EXPECT_EQ(b.init_id, a.init_id);
    EXPECT_EQ(b.lidar_mode, a.lidar_mode);
    EXPECT_EQ(b.columns_per_frame, a.columns_per_frame);
    EXPECT_EQ(b.frames_per_second, a.frames_per_second);
    EXPECT_EQ(b.pixels_per_column, a.pixels_per_column);
    EXPECT_EQ(b.columns_per_packet, a.columns_per_packet);
    EXPECT_EQ(b.udp_profile_lidar, a.udp_profile_lidar);
    EXPECT_EQ(b.udp_profile_imu, a.udp_profile_imu);
    EXPECT_EQ(b.pixel_shift_by_row, a.pixel_shift_by_row);
    EXPECT_EQ(b.column_window, a.column_window);
    EXPECT_EQ(b.beam_altitude_angles_deg, a.beam_altitude_angles_deg);  // exact doubles
    EXPECT_EQ(b.beam_azimuth_angles_deg, a.beam_azimuth_angles_deg);
    EXPECT_EQ(b.lidar_origin_to_beam_origin_mm, a.lidar_origin_to_beam_origin_mm);
    EXPECT_EQ(b.beam_to_lidar_transform, a.beam_to_lidar_transform);
    EXPECT_EQ(b.lidar_to_sensor_transform, a.lidar_to_sensor_transform);
    EXPECT_EQ(b.imu_to_sensor_transform, a.imu_to_sensor_transform);
    EXPECT_EQ(b.udp_port_lidar, a.udp_port_lidar);
    EXPECT_EQ(b.udp_port_imu, a.udp_port_imu);
    EXPECT_EQ(b.udp_dest, a.udp_dest);
    EXPECT_EQ(b.timestamp_mode, a.timestamp_mode);
    EXPECT_EQ(b.azimuth_window_mdeg, a.azimuth_window_mdeg);
    EXPECT_TRUE(b.defaults_applied.empty()) << b.defaults_applied.front();
}

INSTANTIATE_TEST_SUITE_P(AllSamples, SampleMetadata, ::testing::ValuesIn(kSamples),
                         [](const ::testing::TestParamInfo<Expected>& param_info) {
                             std::string name = param_info.param.file;
                             for (char& c : name) {
                                 if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                             }
                             return name;
                         });

TEST(OusterMetadata, ReducedLegacyFileGetsOusterDefaults) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(path, "OS-1-64_sensor_config_reduced.json");
    const SensorInfo info = load_metadata(path);
    EXPECT_DOUBLE_EQ(info.lidar_origin_to_beam_origin_mm, 12.163);
    Eigen::Matrix4d beam_to_lidar = Eigen::Matrix4d::Identity();
    beam_to_lidar(0, 3) = 12.163;
    EXPECT_EQ(info.beam_to_lidar_transform, beam_to_lidar);
    Eigen::Matrix4d l2s = Eigen::Matrix4d::Identity();
    l2s(0, 0) = -1;
    l2s(1, 1) = -1;
    l2s(2, 3) = 36.18;
    EXPECT_EQ(info.lidar_to_sensor_transform, l2s);
    EXPECT_EQ(info.imu_to_sensor_transform(0, 3), 6.253);
    EXPECT_EQ(info.imu_to_sensor_transform(1, 3), -11.775);
    EXPECT_EQ(info.imu_to_sensor_transform(2, 3), 7.645);
    ASSERT_EQ(info.pixel_shift_by_row.size(), 64u);
    for (int row = 0; row < 64; ++row) {
        EXPECT_EQ(info.pixel_shift_by_row[static_cast<std::size_t>(row)], 18 - 6 * (row % 4));
    }
    EXPECT_EQ(info.udp_profile_lidar, UdpProfileLidar::kLegacy);
    EXPECT_FALSE(info.defaults_applied.empty());
    EXPECT_TRUE(has_problem(info.defaults_applied, "lidar_origin_to_beam_origin_mm"));
    EXPECT_TRUE(has_problem(info.defaults_applied, "pixel_shift_by_row"));
}

TEST(OusterMetadata, DefaultsFollowProductLineAndRowCount) {
    EXPECT_DOUBLE_EQ(default_lidar_origin_to_beam_origin_mm("OS-0-128"), 27.67);
    EXPECT_DOUBLE_EQ(default_lidar_origin_to_beam_origin_mm("OS-1-64-AH"), 15.806);
    EXPECT_DOUBLE_EQ(default_lidar_origin_to_beam_origin_mm("OS-2-32-U0"), 13.762);
    EXPECT_DOUBLE_EQ(default_lidar_origin_to_beam_origin_mm(""), 12.163);
    const std::vector<int> s512 = default_pixel_shift_by_row(std::vector<double>(64, 0.0), 64, 512);
    EXPECT_EQ(std::vector<int>(s512.begin(), s512.begin() + 4), (std::vector<int>{9, 6, 3, 0}));
    // Other row counts: from the azimuth angles.
    EXPECT_EQ(default_pixel_shift_by_row({4.16, 1.33, -1.48, -4.29}, 4, 1024),
              (std::vector<int>{12, 4, -4, -12}));
    EXPECT_EQ(default_pixel_shift_by_row({1.0}, 3, 1024), (std::vector<int>{0, 0, 0}));
}

TEST(OusterMetadata, ProfileAndModeNames) {
    for (const auto p : {UdpProfileLidar::kLegacy, UdpProfileLidar::kRng19Rfl8Sig16Nir16,
                         UdpProfileLidar::kRng15Rfl8Nir8, UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
                         UdpProfileLidar::kFusaRng15Rfl8Nir8Dual}) {
        EXPECT_EQ(udp_profile_lidar_from_string(to_string(p)), p);
    }
    EXPECT_FALSE(udp_profile_lidar_from_string("RNG99"));
    EXPECT_EQ(parse_lidar_mode("2048x10"), (std::array<int, 2>{2048, 10}));
    EXPECT_FALSE(parse_lidar_mode("2048x20"));
    EXPECT_FALSE(parse_lidar_mode(""));
}

// --- broken documents ---

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

// Runs the built `lidarfuse inspect` on Ouster sample captures: digest lines equal the
// upstream digest file, the PLY export holds one vertex per return at the reference
// positions, several sensors on one port are summarised separately, errors are clear.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

using ::testing::HasSubstr;

std::string quote(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

std::string run_ok(const std::string& args) {
    std::string out;
    const int status = test::run_command(test::tool_path() + " inspect " + args, &out);
    EXPECT_EQ(status, 0) << out;
    return out;
}

TEST(InspectCommand, DigestLinesEqualTheUpstreamDigestFile) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "OS-0-32-U1_v2.2.0_1024x10.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, "OS-0-32-U1_v2.2.0_1024x10.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(digest, "OS-0-32-U1_v2.2.0_1024x10_digest.json");
    const std::string out = run_ok(quote(pcap) + " --meta " + quote(meta) + " --digest");
    std::ifstream in(digest);
    const auto json = nlohmann::json::parse(in);
    int compared = 0;
    for (const auto& scan : json.at("scans")) {
        const std::string frame = scan.at("FRAME_ID").get<std::string>();
        for (const auto& [key, value] : scan.items()) {
            if (key == "FRAME_ID" || key == "ENCODER_COUNT") continue;
            const std::string line = "frame " + frame + " " + key + " " + value.get<std::string>() +
                                     " sensor 992137000142\n";
            EXPECT_THAT(out, HasSubstr(line));
            ++compared;
        }
    }
    EXPECT_EQ(compared, 10);  // 7 pixel fields of the dual profile + 3 column arrays
    EXPECT_THAT(out, HasSubstr("inspect_992137000142_frames_complete 1 frames\n"));
    EXPECT_THAT(out, HasSubstr("inspect_992137000142_imu_packets 10 packets\n"));
}

TEST(InspectCommand, ExportWritesOneVertexPerReturnAsBinaryPly) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "OS-1-64_1024x10_fw20.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, "OS-1-64_sensor_config_reduced.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(ref, "DERIVED_OS-1-64_1024x10_fw20_reference.json");
    test::TempDir dir("inspect");
    const auto ply = dir.path() / "scan.ply";
    const std::string out =
        run_ok(quote(pcap) + " --meta " + quote(meta) + " --export 189 --out " + quote(ply));
    EXPECT_THAT(out, HasSubstr("export_vertices 16749 points\n"));

    std::ifstream in(ply, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string end = "end_header\n";
    const auto header_end = bytes.find(end);
    ASSERT_NE(header_end, std::string::npos);
    const std::string header = bytes.substr(0, header_end + end.size());
    EXPECT_THAT(header, HasSubstr("format binary_little_endian 1.0\n"));
    EXPECT_THAT(header, HasSubstr("element vertex 16749\n"));
    ASSERT_EQ(bytes.size(), header.size() + 16749u * 12u);

    // Vertices follow the staggered pixel order: the first is pixel (0, 0), a sample of
    // the reference file.
    float first[3];
    std::memcpy(first, bytes.data() + header.size(), sizeof(first));
    std::ifstream rin(ref);
    const auto json = nlohmann::json::parse(rin);
    const auto& px = json.at("sample_pixels").at(0);
    ASSERT_EQ(px.at("row").get<int>(), 0);
    ASSERT_EQ(px.at("col").get<int>(), 0);
    for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(first[k], px.at("xyz_sensor_m")[k].get<double>(), 1e-5) << k;
    }
}

TEST(InspectCommand, SensorsSharingAPortAreSummarisedSeparately) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "same_ports.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta1, "same_ports.1.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta2, "same_ports.2.json");
    const std::string out =
        run_ok(quote(pcap) + " --meta " + quote(meta1) + " --meta " + quote(meta2) + " --frames");
    EXPECT_THAT(out, HasSubstr("scan frame 1542 sensor 122247000785 packets 1 "));
    EXPECT_THAT(out, HasSubstr("scan frame 883 sensor 122239000672 packets 1 "));
    EXPECT_THAT(out, HasSubstr("inspect_122247000785_shape 128x1024 pixels\n"));
    EXPECT_THAT(out, HasSubstr("inspect_122239000672_shape 64x1024 pixels\n"));
    EXPECT_THAT(out, HasSubstr("inspect_122239000672_lidar_packets 1 packets\n"));
}

TEST(InspectCommand, ErrorsNameTheProblem) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "crc_test.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, "crc_test.json");
    std::string out;
    EXPECT_EQ(test::run_command(test::tool_path() + " inspect " + quote(pcap), &out), 1);
    EXPECT_THAT(out, HasSubstr("--meta"));
    out.clear();
    test::TempDir dir("inspect");
    EXPECT_EQ(
        test::run_command(test::tool_path() + " inspect " + quote(pcap) + " --meta " + quote(meta) +
                              " --export 999 --out " + quote(dir.path() / "x.ply"),
                          &out),
        1);
    EXPECT_THAT(out, HasSubstr("no frame with frame_id 999"));
    out.clear();
    EXPECT_EQ(
        test::run_command(
            test::tool_path() + " inspect " + quote(pcap) + " --meta /nonexistent/meta.json", &out),
        1);
    EXPECT_THAT(out, HasSubstr("/nonexistent/meta.json"));
    out.clear();
    EXPECT_EQ(test::run_command(test::tool_path() + " inspect " + quote(pcap) + " --meta " +
                                    quote(meta) + "@300.1.2.3",
                                &out),
              1);
    EXPECT_THAT(out, HasSubstr("not an IPv4 address"));
}

}  // namespace
}  // namespace lidarfuse

// Point-cloud files (drivers/io/cloud_file.hpp): round trips through every encoding, the
// entry point's choice of reader, LZF, and golden reads of the shared real captures. The
// readers' variety and malformed files: cloud_pcd_reader_test, cloud_ply_reader_test.
#include "drivers/io/cloud_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "drivers/io/cloud_lzf.hpp"
#include "tests/drivers/cloud_file_test_support.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::io {
namespace {

using namespace cloud_test;  // NOLINT(google-build-using-namespace): the tests' own helpers
using ::testing::HasSubstr;
using ::testing::StartsWith;

struct Encoding {
    const char* name;
    bool pcd;
    PcdEncoding pcd_encoding;
    PlyEncoding ply_encoding;
};

const Encoding kEncodings[] = {
    {"pcd_ascii", true, PcdEncoding::kAscii, {}},
    {"pcd_binary", true, PcdEncoding::kBinary, {}},
    {"pcd_binary_compressed", true, PcdEncoding::kBinaryCompressed, {}},
    {"ply_ascii", false, {}, PlyEncoding::kAscii},
    {"ply_binary_little_endian", false, {}, PlyEncoding::kBinaryLittleEndian},
    {"ply_binary_big_endian", false, {}, PlyEncoding::kBinaryBigEndian},
};

// GoogleTest finds a parameter's printer by this name.
void PrintTo(const Encoding& e, std::ostream* out) {  // NOLINT(readability-identifier-naming)
    *out << e.name;
}

CloudFile write_and_read(const Encoding& e, const CloudFile& cloud, const fs::path& dir) {
    const fs::path file = dir / (std::string("cloud.") + (e.pcd ? "pcd" : "ply"));
    if (e.pcd) {
        write_pcd(file, cloud, e.pcd_encoding);
    } else {
        write_ply(file, cloud, e.ply_encoding);
    }
    EXPECT_FALSE(fs::exists(file.string() + ".tmp"));
    return read_cloud_file(file);
}

class CloudFileRoundTrip : public ::testing::TestWithParam<Encoding> {};

TEST_P(CloudFileRoundTrip, KeepsEveryFloat32AndIntensityExactly) {
    test::TempDir dir("cloudfile");
    const CloudFile cloud = random_cloud(17, 2000, true);
    const CloudFile back = write_and_read(GetParam(), cloud, dir.path());
    expect_same_cloud(back, cloud);
    EXPECT_EQ(back.num_dropped, 0u);
}

TEST_P(CloudFileRoundTrip, DropsAndCountsNonFiniteAndZeroPoints) {
    test::TempDir dir("cloudfile");
    const Planted planted = with_bad_points(random_cloud(23, 300, true));
    ASSERT_EQ(planted.bad, 6u);
    const CloudFile back = write_and_read(GetParam(), planted.written, dir.path());
    expect_same_cloud(back, planted.expected);
    EXPECT_EQ(back.num_dropped, 6u);
}

TEST_P(CloudFileRoundTrip, WithoutIntensityReadsNone) {
    test::TempDir dir("cloudfile");
    const CloudFile cloud = random_cloud(5, 100, false);
    const CloudFile back = write_and_read(GetParam(), cloud, dir.path());
    expect_same_cloud(back, cloud);
    EXPECT_TRUE(back.intensity.empty());
}

TEST_P(CloudFileRoundTrip, EmptyCloud) {
    test::TempDir dir("cloudfile");
    CloudFile empty;
    const CloudFile back = write_and_read(GetParam(), empty, dir.path());
    EXPECT_TRUE(back.cloud.points.empty());
    EXPECT_EQ(back.num_dropped, 0u);
}

INSTANTIATE_TEST_SUITE_P(AllEncodings, CloudFileRoundTrip, ::testing::ValuesIn(kEncodings),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(CloudFile, ReadCloudFileChoosesTheReaderByExtensionIgnoringCase) {
    test::TempDir dir("cloudfile");
    const CloudFile cloud = random_cloud(3, 50, true);
    write_pcd(dir.path() / "a.PCD", cloud, PcdEncoding::kBinary);
    write_ply(dir.path() / "b.Ply", cloud, PlyEncoding::kBinaryLittleEndian);
    expect_same_cloud(read_cloud_file(dir.path() / "a.PCD"), cloud);
    expect_same_cloud(read_cloud_file(dir.path() / "b.Ply"), cloud);
}

TEST(CloudFile, OtherExtensionsMissingFilesAndMismatchedIntensityAreErrorsNamingTheFile) {
    test::TempDir dir("cloudfile");
    const fs::path xyz = dir.path() / "cloud.xyz";
    std::ofstream(xyz) << "1 2 3\n";
    const std::string wrong = error_of([&] { read_cloud_file(xyz); });
    EXPECT_THAT(wrong, StartsWith(xyz.string() + ": "));
    EXPECT_THAT(wrong, HasSubstr("expected .pcd or .ply"));
    const fs::path missing = dir.path() / "missing.pcd";
    EXPECT_THAT(error_of([&] { read_cloud_file(missing); }),
                StartsWith(missing.string() + ": cannot open"));
    CloudFile bad = random_cloud(1, 10, true);
    bad.intensity.pop_back();
    const fs::path out = dir.path() / "out.pcd";
    EXPECT_THAT(error_of([&] { write_pcd(out, bad, PcdEncoding::kAscii); }),
                AllOf(StartsWith(out.string()), HasSubstr("9 intensities for 10 points")));
    EXPECT_FALSE(fs::exists(out));
}

TEST(CloudLzf, IncompressibleDataIsStoredAsLiteralRunsThatDecompress) {
    std::mt19937 rng(11);
    std::string data(1000, '\0');
    for (auto& c : data) c = static_cast<char>(rng());
    const std::string lzf = lzf_compress_for_pcd(data);
    EXPECT_EQ(lzf.size(), 1000u + 32u);  // one control byte per 32 literals
    EXPECT_EQ(lzf, lzf_literal_runs(data));
    EXPECT_EQ(lzf_decompress_exact(lzf.data(), lzf.size(), data.size(), "x"), data);
}

TEST(CloudLzf, CompressibleDataShrinksAndDecompresses) {
    std::string data;
    for (int i = 0; i < 4000; ++i) data += static_cast<char>(i % 13);
    const std::string lzf = lzf_compress_for_pcd(data);
    EXPECT_LT(lzf.size(), data.size() / 4);
    EXPECT_EQ(lzf_decompress_exact(lzf.data(), lzf.size(), data.size(), "x"), data);
}

// ---- Golden reads of the shared real captures (../shared/data/real, see SOURCES.md) ----
//
// Values computed once, independently of this reader, by a Python 3 script using only the
// standard library: the header split by hand, ascii values through float() and then
// struct.pack('<f') (float32 rounding), binary_compressed through an LZF decoder written in
// that script and struct.unpack_from on the field arrays; points with a non-finite
// coordinate or exactly (0, 0, 0) dropped; printed with '%.9g' (exact for float32).
struct Golden {
    const char* file;  // relative to the data folder
    std::size_t kept;
    std::size_t dropped;
    float first[4];  // x y z intensity of the first kept point
    float last[4];   // and of the last
};

const Golden kGolden[] = {
    {"real/edgar_ouster_pair/frontleft.pcd",
     81381,
     49691,
     {-11.8198242f, 1.46738505f, 4.63315773f, 25.0f},
     {-0.0101432027f, -0.29599753f, -0.0764857307f, 327.0f}},
    {"real/edgar_ouster_pair/frontright.pcd",
     84595,
     46477,
     {0.0219358616f, 0.28953442f, 0.141753495f, 41.0f},
     {-0.348147452f, -0.0660969168f, -0.100624077f, 82.0f}},
    {"real/opencalib_road_rig/top.pcd",
     92677,
     0,
     {-9.56822777f, -0.140440732f, -2.20481682f, 52.0f},
     {-29.47365f, -1.91931665f, -2.52751684f, 47.0f}},
    {"real/opencalib_road_rig/left.pcd",
     8572,
     0,
     {-5.31684446f, 1.99730551f, -3.43969917f, 16.0f},
     {-10.1744127f, -20.2983685f, -0.332904726f, 14.0f}},
    {"real/opencalib_road_rig/right.pcd",
     9248,
     0,
     {-8.12848186f, 16.7801762f, -4.64844561f, 21.0f},
     {-7.75295877f, -1.37878072f, -5.06705952f, 13.0f}},
};

// GoogleTest finds a parameter's printer by this name.
void PrintTo(const Golden& g, std::ostream* out) {  // NOLINT(readability-identifier-naming)
    *out << g.file;
}

class CloudFileGolden : public ::testing::TestWithParam<Golden> {};

void expect_point(const CloudFile& got, std::size_t i, const float (&expected)[4]) {
    SCOPED_TRACE("point " + std::to_string(i));
    EXPECT_EQ(got.cloud.points[i], Eigen::Vector3d(expected[0], expected[1], expected[2]));
    EXPECT_EQ(got.intensity[i], expected[3]);
}

TEST_P(CloudFileGolden, KeptCountAndFirstAndLastPoints) {
    const Golden& g = GetParam();
    const auto dir = test::data_dir();
    if (!dir || !fs::exists(*dir / g.file)) {
        GTEST_SKIP() << "real capture " << g.file
                     << " not found (set LIDARFUSE_DATA_DIR to the shared/data folder)";
    }
    const CloudFile got = read_cloud_file(*dir / g.file);
    ASSERT_EQ(got.cloud.points.size(), g.kept);
    ASSERT_EQ(got.intensity.size(), g.kept);
    EXPECT_EQ(got.num_dropped, g.dropped);
    expect_point(got, 0, g.first);
    expect_point(got, g.kept - 1, g.last);
}

INSTANTIATE_TEST_SUITE_P(RealCaptures, CloudFileGolden, ::testing::ValuesIn(kGolden),
                         [](const auto& param_info) {
                             const fs::path file(param_info.param.file);
                             return file.parent_path().filename().string() + "_" +
                                    file.stem().string();
                         });

}  // namespace
}  // namespace lidarfuse::io

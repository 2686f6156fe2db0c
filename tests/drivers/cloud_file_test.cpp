// Point-cloud files (drivers/io/cloud_file.hpp): round trips through every encoding, golden
// reads of the shared real captures, the format's variety (field order, padding, COUNT,
// types, viewpoint, PLY elements with lists), and malformed files built from good ones.
#include "drivers/io/cloud_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <random>

#include "drivers/io/cloud_lzf.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::io {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

std::string file_bytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// Appends `value` in the given byte order (the tests build binary PCD / PLY by hand).
template <typename T>
void put(std::string* out, T value, bool big_endian = false) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    std::uint16_t probe = 1;
    const bool host_little = *reinterpret_cast<unsigned char*>(&probe) == 1;
    for (std::size_t i = 0; i < sizeof(T); ++i) {
        const std::size_t k = (host_little != big_endian) ? i : sizeof(T) - 1 - i;
        out->push_back(static_cast<char>(bytes[k]));
    }
}

template <typename... T>
void put_all(std::string* out, bool big_endian, T... values) {
    (put(out, values, big_endian), ...);
}

// Points whose coordinates are float32 values (so every encoding can keep them exactly):
// a wide range, plus values that test the ascii digits (denormal, FLT_MAX, -0 in one axis).
CloudFile random_cloud(std::uint32_t seed, std::size_t n, bool with_intensity) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> coordinate(-250.0f, 250.0f);
    std::uniform_real_distribution<float> intensity(0.0f, 4096.0f);
    CloudFile cloud;
    for (std::size_t i = 0; i < n; ++i) {
        const float x = coordinate(rng), y = coordinate(rng), z = coordinate(rng);  // in order
        cloud.cloud.points.emplace_back(x, y, z);
        if (with_intensity) cloud.intensity.push_back(intensity(rng));
    }
    if (n >= 4) {
        using V = Eigen::Vector3d;
        cloud.cloud.points[1] = V(std::numeric_limits<float>::denorm_min(), -0.0f, 1e-30f);
        cloud.cloud.points[2] = V(std::numeric_limits<float>::max(), -1.17549435e-38f, 0.1f);
        cloud.cloud.points[3] = V(0.0f, 0.0f, 3.0f);  // zero in two axes only: kept
    }
    return cloud;
}

// Every bad point kind inserted at a known place, and the cloud a reader must return.
struct Planted {
    CloudFile written;
    CloudFile expected;
    std::size_t bad = 0;
};

Planted with_bad_points(const CloudFile& good) {
    using V = Eigen::Vector3d;
    const std::vector<V> bad = {V(kNan, 1, 2), V(1, kInf, 2),    V(1, 2, -kInf),
                                V(0, 0, 0),    V(-0.0, 0, -0.0), V(kNan, kNan, kNan)};
    Planted p;
    p.expected = good;
    for (std::size_t i = 0; i < good.cloud.points.size(); ++i) {
        if (i % 7 == 0 && p.bad < bad.size()) {
            p.written.cloud.points.push_back(bad[p.bad++]);
            if (!good.intensity.empty()) p.written.intensity.push_back(99.0f);
        }
        p.written.cloud.points.push_back(good.cloud.points[i]);
        if (!good.intensity.empty()) p.written.intensity.push_back(good.intensity[i]);
    }
    return p;
}

void expect_same_cloud(const CloudFile& got, const CloudFile& expected) {
    ASSERT_EQ(got.cloud.points.size(), expected.cloud.points.size());
    ASSERT_EQ(got.intensity.size(), expected.intensity.size());
    for (std::size_t i = 0; i < got.cloud.points.size(); ++i) {
        // Exact: float32 in, float32 out, whatever the encoding.
        ASSERT_EQ(got.cloud.points[i], expected.cloud.points[i]) << "point " << i;
        if (!got.intensity.empty()) {
            ASSERT_EQ(got.intensity[i], expected.intensity[i]) << "point " << i;
        }
    }
}

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

void PrintTo(const Encoding& e, std::ostream* out) { *out << e.name; }

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

std::string error_of(const std::function<void()>& run) {
    try {
        run();
    } catch (const std::runtime_error& error) {
        return error.what();
    }
    return "(no error)";
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

// ---- PCD variety: field order, padding, COUNT > 1, integer and double fields ----

struct Record {
    double x, y, z;
    std::uint16_t intensity;
    std::int16_t ring;
};

const Record kRecords[] = {
    {1.5, -2.25, 1e-3, 65535, -3},
    {0.0, 0.0, 0.0, 7, 1},  // no return: dropped
    {std::nan(""), 1.0, 1.0, 8, 2},
    {123456.789, 7.0, -8.0, 0, 4},
};

const char* kMixedHeader =
    "# .PCD v0.7 - hand made\nVERSION 0.7\nFIELDS intensity _ normal z y x ring\n"
    "SIZE 2 1 4 8 4 8 2\nTYPE U U F F F F I\nCOUNT 1 3 3 1 1 1 1\nWIDTH 2\nHEIGHT 2\n"
    "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA ";

// The fields of kMixedHeader, each appending one record's value(s).
std::vector<std::function<void(std::string*, const Record&)>> mixed_fields() {
    return {
        [](std::string* o, const Record& r) { put(o, r.intensity); },
        [](std::string* o, const Record&) { o->append("\xAB\xAB\xAB"); },
        [](std::string* o, const Record&) { put_all(o, false, 0.5f, -0.5f, 2.0f); },
        [](std::string* o, const Record& r) { put(o, r.z); },
        [](std::string* o, const Record& r) { put(o, static_cast<float>(r.y)); },
        [](std::string* o, const Record& r) { put(o, r.x); },
        [](std::string* o, const Record& r) { put(o, r.ring); },
    };
}

void expect_mixed_records(const CloudFile& got) {
    ASSERT_EQ(got.cloud.points.size(), 2u);
    EXPECT_EQ(got.num_dropped, 2u);
    EXPECT_EQ(got.cloud.points[0], Eigen::Vector3d(1.5, -2.25, 1e-3));
    EXPECT_EQ(got.cloud.points[1], Eigen::Vector3d(123456.789, 7.0, -8.0));
    EXPECT_EQ(got.intensity, (std::vector<float>{65535.0f, 0.0f}));
}

TEST(PcdReader, BinaryWithAnyFieldOrderPaddingCountsAndTypes) {
    std::string bytes = std::string(kMixedHeader) + "binary\n";
    for (const Record& r : kRecords) {
        for (const auto& field : mixed_fields()) field(&bytes, r);
    }
    expect_mixed_records(read_pcd(bytes, "mixed.pcd"));
}

TEST(PcdReader, BinaryCompressedStoresTheSameFieldsAsArrays) {
    std::string columns;
    for (const auto& field : mixed_fields()) {
        for (const Record& r : kRecords) field(&columns, r);
    }
    ASSERT_EQ(columns.size(), 4u * 39u);
    const std::string lzf = lzf_compress_for_pcd(columns);
    std::string bytes = std::string(kMixedHeader) + "binary_compressed\n";
    put(&bytes, static_cast<std::uint32_t>(lzf.size()));
    put(&bytes, static_cast<std::uint32_t>(columns.size()));
    expect_mixed_records(read_pcd(bytes + lzf, "mixed.pcd"));
}

TEST(PcdReader, AsciiWithAnyFieldOrderPaddingCountsAndTypes) {
    const std::string bytes = std::string(kMixedHeader) +
                              "ascii\n"
                              "65535 0 0 0 0.5 -0.5 2 0.001 -2.25 1.5 -3\n"
                              "7 0 0 0 0.5 -0.5 2 0 0 0 1\n"
                              "8 0 0 0 0.5 -0.5 2 1 1 nan 2\n"
                              "0 0 0 0 0.5 -0.5 2 -8 7 123456.789 4\n";
    expect_mixed_records(read_pcd(bytes, "mixed.pcd"));
}

TEST(PcdReader, AppliesTheViewpointAfterDroppingNoReturnPixels) {
    // 90 degrees about z, then (1, 2, 3): p' = q p + t.
    const std::string bytes =
        "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 3\n"
        "VIEWPOINT 1 2 3 0.70710678 0 0 0.70710678\nDATA ascii\n1 0 0\n0 0 0\n0 2 0\n";
    const CloudFile got = read_pcd(bytes, "viewpoint.pcd");
    ASSERT_EQ(got.cloud.points.size(), 2u);
    EXPECT_EQ(got.num_dropped, 1u);
    EXPECT_TRUE(got.cloud.points[0].isApprox(Eigen::Vector3d(1, 3, 3), 1e-7));
    EXPECT_TRUE(got.cloud.points[1].isApprox(Eigen::Vector3d(-1, 2, 3), 1e-7));
    EXPECT_TRUE(got.intensity.empty());
}

TEST(PcdReader, Version05HeaderWithColumnsCrLfAndNoCountHeightOrViewpoint) {
    const std::string bytes =
        "# old\r\nVERSION .5\r\nCOLUMNS x y z\r\nSIZE 4 4 4\r\nTYPE F F F\r\nWIDTH 2\r\n"
        "POINTS 2\r\nDATA ascii\r\n1 2 3\r\n\r\n4 5 6\r\n";
    const CloudFile got = read_pcd(bytes, "old.pcd");
    ASSERT_EQ(got.cloud.points.size(), 2u);
    EXPECT_EQ(got.cloud.points[1], Eigen::Vector3d(4, 5, 6));
}

// ---- PLY variety: elements with lists before and after vertex, mixed types ----

std::string ply_header(const char* format) {
    return std::string("ply\nformat ") + format +
           " 1.0\ncomment made by hand\nelement camera 1\nproperty list uchar float intrinsics\n"
           "property int id\nobj_info between elements\nelement vertex 3\nproperty double x\n"
           "property float32 y\nproperty short z\nproperty list ushort int tags\n"
           "property uchar intensity\nproperty float nx\nelement face 2\ncomment inside\n"
           "property list uchar int vertex_indices\nend_header\n";
}

std::string binary_ply(bool big) {
    std::string b = ply_header(big ? "binary_big_endian" : "binary_little_endian");
    put_all(&b, big, std::uint8_t{2}, 0.5f, 1.5f, 7);  // camera: list of 2 floats, int id
    const auto vertex = [&](double x, float y, std::int16_t z, std::vector<int> tags,
                            std::uint8_t intensity) {
        put_all(&b, big, x, y, z);
        put(&b, static_cast<std::uint16_t>(tags.size()), big);
        for (int t : tags) put(&b, t, big);
        put_all(&b, big, intensity, 0.25f);
    };
    vertex(1.25, -2.5f, 3, {1, 2, 3}, 200);
    vertex(0.0, 0.0f, 0, {}, 5);
    vertex(-1e5, 0.125f, -7, {9}, 255);
    for (const std::vector<int>& face : {std::vector<int>{0, 1, 2}, std::vector<int>{2, 1, 0, 5}}) {
        put(&b, static_cast<std::uint8_t>(face.size()), big);
        for (int v : face) put(&b, v, big);
    }
    return b;
}

void expect_ply_vertices(const CloudFile& got) {
    ASSERT_EQ(got.cloud.points.size(), 2u);
    EXPECT_EQ(got.num_dropped, 1u);
    EXPECT_EQ(got.cloud.points[0], Eigen::Vector3d(1.25, -2.5, 3));
    EXPECT_EQ(got.cloud.points[1], Eigen::Vector3d(-1e5, 0.125, -7));
    EXPECT_EQ(got.intensity, (std::vector<float>{200.0f, 255.0f}));
}

TEST(PlyReader, BinaryLittleEndianSkipsListsBeforeInAndAfterVertex) {
    expect_ply_vertices(read_ply(binary_ply(false), "lists.ply"));
}

TEST(PlyReader, BinaryBigEndianSkipsListsBeforeInAndAfterVertex) {
    expect_ply_vertices(read_ply(binary_ply(true), "lists.ply"));
}

TEST(PlyReader, AsciiSkipsListsBeforeInAndAfterVertex) {
    const std::string text = ply_header("ascii") +
                             "2 0.5 1.5 7\n"
                             "1.25 -2.5 3 3 1 2 3 200 0.25\n"
                             "0 0 0 0 5 0.25\n\n"
                             "-1e5 0.125 -7 1 9 255 0.25\n"
                             "3 0 1 2\n4 2 1 0 5\n";
    expect_ply_vertices(read_ply(text, "lists.ply"));
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

void PrintTo(const Golden& g, std::ostream* out) { *out << g.file; }

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

// ---- Malformed PCD, each built from a good file written by write_pcd ----

std::string good_pcd(PcdEncoding encoding, std::size_t n = 20) {
    test::TempDir dir("cloudfile");
    write_pcd(dir.path() / "good.pcd", random_cloud(31, n, true), encoding);
    return file_bytes(dir.path() / "good.pcd");
}

std::string replaced(std::string bytes, const std::string& from, const std::string& to) {
    const auto at = bytes.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) bytes.replace(at, from.size(), to);
    return bytes;
}

// Where the binary data starts (after the DATA line).
std::size_t data_start(const std::string& bytes) {
    return bytes.find('\n', bytes.find("\nDATA ") + 1) + 1;
}

void expect_pcd_error(const std::string& bytes, const std::string& expected) {
    const std::string message = error_of([&] { read_pcd(bytes, "bad.pcd"); });
    EXPECT_THAT(message, StartsWith("bad.pcd:"));
    EXPECT_THAT(message, HasSubstr(expected));
}

// PCL before 1.8 stretched binary files to a page plus the data; the zero bytes after the
// data are no points and no error, any other trailing byte is.
TEST(PcdReader, AcceptsTheZeroPagePaddingOfOlderPclWriters) {
    const CloudFile expected = read_pcd(good_pcd(PcdEncoding::kBinary), "good.pcd");
    const std::string padding(4096 - 180, '\0');
    for (const PcdEncoding encoding : {PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
        const std::string good = good_pcd(encoding);
        expect_same_cloud(read_pcd(good + padding, "padded.pcd"), expected);
        expect_pcd_error(good + padding + "x", encoding == PcdEncoding::kBinary
                                                   ? "bytes after the last point"
                                                   : "trailing data that is not zero padding");
        expect_pcd_error(good + std::string(70000, '\0'), "");
    }
}

TEST(PcdMalformed, TruncatedData) {
    const std::string binary = good_pcd(PcdEncoding::kBinary);
    expect_pcd_error(binary.substr(0, binary.size() - 3),
                     "truncated: DATA binary needs POINTS x point size = 20 x 16 = 320 bytes after "
                     "the header, the file has 317");
    const std::string compressed = good_pcd(PcdEncoding::kBinaryCompressed);
    expect_pcd_error(compressed.substr(0, compressed.size() - 1), "does not match the");
    expect_pcd_error(compressed.substr(0, data_start(compressed) + 5),
                     "needs two uint32 sizes (compressed, uncompressed)");
    const std::string ascii = good_pcd(PcdEncoding::kAscii);
    expect_pcd_error(ascii.substr(0, ascii.rfind('\n', ascii.size() - 2) + 1),
                     "truncated: 19 ascii rows, POINTS says 20");
}

TEST(PcdMalformed, HeaderLyingAboutPoints) {
    const auto more = [](const std::string& bytes) {
        return replaced(replaced(bytes, "WIDTH 20", "WIDTH 21"), "POINTS 20", "POINTS 21");
    };
    expect_pcd_error(more(good_pcd(PcdEncoding::kAscii)),
                     "truncated: 20 ascii rows, POINTS says 21");
    expect_pcd_error(more(good_pcd(PcdEncoding::kBinary)), "needs POINTS x point size = 21 x 16");
    expect_pcd_error(more(good_pcd(PcdEncoding::kBinaryCompressed)),
                     "uncompressed size 320 does not match POINTS x point size = 21 x 16 = 336");
    const auto fewer = [](const std::string& bytes) {
        return replaced(replaced(bytes, "WIDTH 20", "WIDTH 19"), "POINTS 20", "POINTS 19");
    };
    expect_pcd_error(fewer(good_pcd(PcdEncoding::kAscii)), ":31: more ascii rows than POINTS 19");
    expect_pcd_error(fewer(good_pcd(PcdEncoding::kBinary)), "16 bytes after the last point");
    expect_pcd_error(replaced(good_pcd(PcdEncoding::kAscii), "POINTS 20", "POINTS 21"),
                     "POINTS 21 is not WIDTH x HEIGHT = 20");
}

TEST(PcdMalformed, CompressedAndUncompressedSizesThatDoNotMatch) {
    const std::string good = good_pcd(PcdEncoding::kBinaryCompressed);
    const std::size_t at = data_start(good);
    std::string bad = good;
    bad[at] = static_cast<char>(bad[at] + 1);  // compressed size one more than the bytes
    expect_pcd_error(bad, "compressed size");
    bad = good;
    bad[at + 4] = static_cast<char>(bad[at + 4] + 16);  // uncompressed size 336, POINTS says 320
    expect_pcd_error(bad, "uncompressed size 336 does not match POINTS x point size");
    // The stream itself decodes to more than the header's POINTS x point size.
    bad = replaced(replaced(good, "WIDTH 20", "WIDTH 19"), "POINTS 20", "POINTS 19");
    const std::size_t at19 = data_start(bad);
    bad[at19 + 4] = static_cast<char>(bad[at19 + 4] - 16);
    expect_pcd_error(bad, "LZF data decompresses to more than 304 bytes");
    bad = good;
    bad[at + 8] = static_cast<char>(0xE0);  // a back reference before any output
    expect_pcd_error(bad, "corrupt LZF data");
}

TEST(PcdMalformed, MissingCoordinatesAndUnsupportedTypes) {
    const std::string good = good_pcd(PcdEncoding::kBinary);
    expect_pcd_error(replaced(good, "FIELDS x y z", "FIELDS x y w"),
                     "no field z (expected x, y and z)");
    expect_pcd_error(replaced(good, "SIZE 4 4 4 4", "SIZE 4 4 4 2"),
                     "field intensity: unsupported TYPE F with SIZE 2");
    expect_pcd_error(replaced(good, "TYPE F F F F", "TYPE F F F Q"), "unsupported TYPE Q");
    expect_pcd_error(replaced(good, "TYPE F F F F", "TYPE U F F F"),
                     "field x must be TYPE F, SIZE 4 or 8, COUNT 1 (it is uint32 x 1)");
    expect_pcd_error(replaced(good, "COUNT 1 1 1 1", "COUNT 1 1 1 2"),
                     "field intensity must have COUNT 1");
    expect_pcd_error(replaced(good, "SIZE 4 4 4 4", "SIZE 4 4 4"),
                     "SIZE has 3 values for 4 FIELDS");
    expect_pcd_error(replaced(good, "FIELDS x y z intensity", "FIELDS x y x intensity"),
                     "field x appears twice");
}

TEST(PcdMalformed, EveryHeaderProblemIsListed) {
    std::string bad = replaced(good_pcd(PcdEncoding::kBinary), "VERSION 0.7", "VERSION 0.9");
    bad = replaced(bad, "TYPE F F F F", "TYPE F F F X");
    bad = replaced(bad, "VIEWPOINT 0 0 0 1 0 0 0", "VIEWPOINT 0 0 0 2 0 0 0");
    const std::string message = error_of([&] { read_pcd(bad, "bad.pcd"); });
    EXPECT_THAT(message, StartsWith("bad.pcd: bad PCD header: line 2: unsupported VERSION"));
    EXPECT_THAT(message, HasSubstr("line 5: field intensity: unsupported TYPE X"));
    EXPECT_THAT(message,
                HasSubstr("line 9: VIEWPOINT quaternion (qw qx qy qz) must have unit length"));
}

TEST(PcdMalformed, BadAsciiRows) {
    const std::string good = good_pcd(PcdEncoding::kAscii, 3);
    const std::size_t row = data_start(good);  // line 12
    const std::size_t end = good.find('\n', row);
    std::string bad = good;
    bad.insert(end, " 7");
    expect_pcd_error(bad,
                     "bad.pcd:12: expected 4 values per row (FIELDS with their COUNTs), got 5");
    bad = good;
    bad.insert(end, "abc");
    expect_pcd_error(bad, "bad.pcd:12: value 4 (field intensity) \"");
    expect_pcd_error(bad, "\" is not a number");
    bad = good;
    bad.replace(row, end - row, "1 2");
    expect_pcd_error(bad, "bad.pcd:12: expected 4 values per row");
}

TEST(PcdMalformed, AbsurdSizesAreRefusedBeforeAllocating) {
    const std::string binary = good_pcd(PcdEncoding::kBinary);
    expect_pcd_error(
        replaced(replaced(binary, "WIDTH 20", "WIDTH 4294967296"), "HEIGHT 1", "HEIGHT 4294967296"),
        "WIDTH x HEIGHT (4294967296 x 4294967296) overflows 64 bits");
    const auto huge = [](const std::string& bytes, const std::string& n) {
        return replaced(replaced(bytes, "WIDTH 20", "WIDTH " + n), "POINTS 20", "POINTS " + n);
    };
    expect_pcd_error(huge(binary, "2000000000000000000"),
                     "POINTS x point size (2000000000000000000 x 16) overflows 64 bits");
    expect_pcd_error(huge(binary, "1000000000000"),
                     "needs POINTS x point size = 1000000000000 x 16");
    expect_pcd_error(huge(good_pcd(PcdEncoding::kAscii), "1000000000000"),
                     "truncated: POINTS 1000000000000 rows of 4 values cannot fit in the");
    // 250 M points = 4e9 bytes claimed, and the uncompressed size saying the same.
    std::string compressed = huge(good_pcd(PcdEncoding::kBinaryCompressed), "250000000");
    const std::size_t at = data_start(compressed);
    std::string claimed;
    put(&claimed, std::uint32_t{4000000000u});
    compressed.replace(at + 4, 4, claimed);
    expect_pcd_error(compressed, "uncompressed size 4000000000 cannot come from");
    expect_pcd_error(replaced(binary, "COUNT 1 1 1 1", "COUNT 1 1 1 9999999"),
                     "COUNT must be an integer from 1 to 1048576");
    std::string wide = replaced(binary, "FIELDS x y z intensity\n", "FIELDS x y z intensity big\n");
    wide = replaced(wide, "SIZE 4 4 4 4\n", "SIZE 4 4 4 4 8\n");
    wide = replaced(wide, "TYPE F F F F\n", "TYPE F F F F F\n");
    wide = replaced(wide, "COUNT 1 1 1 1\n", "COUNT 1 1 1 1 1048576\n");
    expect_pcd_error(wide, "a point of more than 1048576 bytes");
}

TEST(PcdMalformed, HeaderSyntax) {
    const std::string good = good_pcd(PcdEncoding::kBinary);
    expect_pcd_error("", "bad.pcd: empty file");
    expect_pcd_error(good.substr(0, good.find("DATA")), "no DATA line");
    expect_pcd_error(replaced(good, "HEIGHT 1", "HIGHT 1"),
                     "bad.pcd:8: unknown PCD header keyword \"HIGHT\"");
    expect_pcd_error(replaced(good, "HEIGHT 1", "WIDTH 20"), "bad.pcd:8: WIDTH appears twice");
    expect_pcd_error(replaced(good, "DATA binary", "DATA zip"), "unsupported DATA");
    expect_pcd_error(replaced(good, "WIDTH 20", "WIDTH -20"),
                     "WIDTH must be one non-negative integer");
    expect_pcd_error(replaced(good, "VIEWPOINT 0 0 0 1 0 0 0", "VIEWPOINT 0 0 0 1 0 0"),
                     "VIEWPOINT must be 7 finite numbers");
}

// ---- Malformed PLY, each built from a good file ----

void expect_ply_error(const std::string& bytes, const std::string& expected) {
    const std::string message = error_of([&] { read_ply(bytes, "bad.ply"); });
    EXPECT_THAT(message, StartsWith("bad.ply:"));
    EXPECT_THAT(message, HasSubstr(expected));
}

TEST(PlyMalformed, HeaderProblems) {
    const std::string good = binary_ply(false);
    expect_ply_error("", "not a PLY file");
    expect_ply_error(replaced(good, "ply\n", "PLY\n"), "not a PLY file");
    expect_ply_error(good.substr(0, good.find("end_header")), "no end_header line");
    expect_ply_error(replaced(good, "format binary_little_endian 1.0\n", ""), "no format line");
    expect_ply_error(replaced(good, "binary_little_endian 1.0", "binary_middle_endian 1.0"),
                     "bad.ply:2: unknown format \"binary_middle_endian\"");
    expect_ply_error(replaced(good, "element vertex 3", "element points 3"), "no element vertex");
    expect_ply_error(replaced(good, "property short z", "property short w"),
                     "element vertex needs a scalar property z");
    expect_ply_error(replaced(good, "property short z", "property list uchar short z"),
                     "element vertex needs a scalar property z");
    expect_ply_error(replaced(good, "property short z", "property half z"),
                     "bad.ply:11: unknown PLY type \"half\"");
    expect_ply_error(replaced(good, "list uchar int vertex", "list float int vertex"),
                     "the count type must be an integer type");
    expect_ply_error(replaced(good, "property float nx", "property float x"),
                     "element vertex: property x appears twice");
    expect_ply_error(replaced(good, "element camera 1\n", "property int id\nelement camera 1\n"),
                     "bad.ply:4: property before any element");
    expect_ply_error(replaced(good, "comment made by hand", "remark made by hand"),
                     "bad.ply:3: unknown PLY header keyword \"remark\"");
    expect_ply_error(replaced(good, "element face 2", "element face -2"),
                     "non-negative integer count");
    expect_ply_error(replaced(good, "end_header", "element empty 4\nend_header"),
                     "element empty has 4 entries but no properties");
}

TEST(PlyMalformed, BinaryTruncatedTrailingAndAbsurd) {
    const std::string good = binary_ply(false);
    expect_ply_error(good.substr(0, good.size() - 2),
                     "truncated: element face entry 2 of 2 runs past the end of the file");
    const std::size_t vertex_end = good.size() - (1 + 3 * 4) - (1 + 4 * 4);
    expect_ply_error(good.substr(0, vertex_end - 1), "truncated: element vertex entry 3 of 3");
    expect_ply_error(good + "xx", "2 bytes after the last element");
    expect_ply_error(replaced(good, "element vertex 3", "element vertex 1000000000000000"),
                     "truncated: element vertex announces 1000000000000000 entries of at least");
    // A face list whose length says more items than the file holds.
    std::string longer = good;
    longer[good.size() - (1 + 4 * 4)] = static_cast<char>(200);
    expect_ply_error(longer, "truncated: element face entry 2 of 2 runs past the end");
    std::string negative = replaced(good, "list uchar int vertex", "list char int vertex");
    negative[negative.size() - (1 + 4 * 4)] = static_cast<char>(-1);
    expect_ply_error(negative,
                     "element face entry 2 of 2: list vertex_indices has a negative length");
}

TEST(PlyMalformed, AsciiWrongValueCountsAndMissingEntries) {
    const std::string header = ply_header("ascii");
    const std::string camera = "2 0.5 1.5 7\n";
    const std::string v1 = "1.25 -2.5 3 3 1 2 3 200 0.25\n", v2 = "0 0 0 0 5 0.25\n";
    const std::string v3 = "-1e5 0.125 -7 1 9 255 0.25\n", faces = "3 0 1 2\n4 2 1 0 5\n";
    ASSERT_NO_THROW(read_ply(header + camera + v1 + v2 + v3 + faces, "good.ply"));
    // Line 20 is the first vertex.
    expect_ply_error(header + camera + "1.25 -2.5 3 3 1 2 3 200 0.25 9\n" + v2 + v3 + faces,
                     "bad.ply:20: element vertex: expected 9 values, got 10");
    expect_ply_error(header + camera + "1.25 -2.5 3 3 1 2 3 200\n" + v2 + v3 + faces,
                     "bad.ply:20: element vertex: too few values (nx missing)");
    expect_ply_error(header + camera + "1.25 -2.5 3 9 1 2 3 200 0.25\n" + v2 + v3 + faces,
                     "bad.ply:20: list tags: expected a length and that many values");
    expect_ply_error(header + camera + "1.25 -2.5 zz 3 1 2 3 200 0.25\n" + v2 + v3 + faces,
                     "bad.ply:20: property z: \"zz\" is not a number");
    expect_ply_error(header + camera + v1 + v2 + v3,
                     "truncated: element face entry 1 of 2 is missing");
    expect_ply_error(header + camera + v1 + v2 + v3 + faces + "1 2 3\n",
                     "bad.ply:25: data after the last element");
}

}  // namespace
}  // namespace lidarfuse::io

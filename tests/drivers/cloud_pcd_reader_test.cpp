// The PCD reader (drivers/io/cloud_file.hpp): any field order, padding, COUNT and type,
// viewpoint, older headers and PCL's zero padding; malformed files built from good ones.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "drivers/io/cloud_file.hpp"
#include "drivers/io/cloud_lzf.hpp"
#include "tests/drivers/cloud_file_test_support.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::io {
namespace {

using namespace cloud_test;  // NOLINT(google-build-using-namespace): the tests' own helpers
using ::testing::HasSubstr;
using ::testing::StartsWith;

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

const char* const kMixedHeader =
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

// ---- Malformed PCD, each built from a good file written by write_pcd ----

std::string good_pcd(PcdEncoding encoding, std::size_t n = 20) {
    test::TempDir dir("cloudfile");
    write_pcd(dir.path() / "good.pcd", random_cloud(31, n, true), encoding);
    return file_bytes(dir.path() / "good.pcd");
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

}  // namespace
}  // namespace lidarfuse::io

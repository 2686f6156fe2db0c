// The PLY reader (drivers/io/cloud_file.hpp): elements with lists before, in and after the
// vertex element in every format; malformed files built from good ones.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "drivers/io/cloud_file.hpp"
#include "tests/drivers/cloud_file_test_support.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::io {
namespace {

using namespace cloud_test;  // NOLINT(google-build-using-namespace): the tests' own helpers
using ::testing::HasSubstr;
using ::testing::StartsWith;

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

#include "drivers/io/pose_csv.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "tests/support/test_data.hpp"

namespace lidarfuse::io {
namespace {

using ::testing::HasSubstr;

TEST(PoseCsv, RoundTripKeepsPosesToMicrometres) {
    std::vector<PoseRecord> records;
    for (int i = 0; i < 5; ++i) {
        PoseRecord r;
        r.frame = i;
        r.sensor = "lidar" + std::to_string(i % 2);
        r.t_ns = 1'700'000'000'000'000'000LL + i * 50'000'000LL;
        r.pose.linear() = Eigen::AngleAxisd(0.3 * i - 0.7, Eigen::Vector3d(1, 2, 3).normalized())
                              .toRotationMatrix();
        r.pose.translation() = Eigen::Vector3d(1.234567 * i, -20.5, 6.000001);
        records.push_back(r);
    }
    test::TempDir dir("posecsv");
    write_pose_csv(dir.path() / "poses.csv", records);
    std::ifstream in(dir.path() / "poses.csv");
    std::string header;
    std::getline(in, header);
    EXPECT_EQ(header, "frame,sensor,t_ns,x,y,z,qw,qx,qy,qz");
    const auto back = read_pose_csv(dir.path() / "poses.csv");
    ASSERT_EQ(back.size(), records.size());
    for (std::size_t i = 0; i < back.size(); ++i) {
        EXPECT_EQ(back[i].frame, records[i].frame);
        EXPECT_EQ(back[i].sensor, records[i].sensor);
        EXPECT_EQ(back[i].t_ns, records[i].t_ns);
        EXPECT_LT((back[i].pose.translation() - records[i].pose.translation()).norm(), 1e-6);
        EXPECT_TRUE(back[i].pose.rotation().isApprox(records[i].pose.rotation(), 1e-8));
    }
}

void expect_error(const std::string& text, const std::string& expected) {
    std::istringstream in(text);
    try {
        parse_pose_csv(in, "x.csv");
        FAIL() << "expected an error containing " << expected;
    } catch (const std::runtime_error& error) {
        EXPECT_THAT(error.what(), HasSubstr(expected));
    }
}

// Rows become per-sensor trajectories in file order, each position moved by the offset and
// each rotation kept.
TEST(PoseCsv, RecordsBecomeTrajectoriesShiftedByTheOffset) {
    std::vector<PoseRecord> records(3);
    records[0] = {4, "b", 400, Eigen::Isometry3d::Identity()};
    records[1] = {5, "a", 500, Eigen::Isometry3d::Identity()};
    records[2] = {6, "b", 600, Eigen::Isometry3d::Identity()};
    records[2].pose.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    records[2].pose.translation() = Eigen::Vector3d(1, 2, 3);
    const Eigen::Vector3d offset(500000, 5400000, 100);
    const core::Trajectories t = to_trajectories(records, offset);
    ASSERT_EQ(t.size(), 2u);
    ASSERT_EQ(t.at("b").size(), 2u);
    ASSERT_EQ(t.at("a").size(), 1u);
    EXPECT_EQ(t.at("b")[1].frame, 6);
    EXPECT_EQ(t.at("b")[1].t_ns, 600);
    EXPECT_TRUE(t.at("b")[1].pose.translation().isApprox(Eigen::Vector3d(500001, 5400002, 103)));
    EXPECT_TRUE(t.at("b")[1].pose.linear().isApprox(records[2].pose.linear()));
    EXPECT_TRUE(to_trajectories(records).at("a")[0].pose.translation().isZero());
}

TEST(PoseCsv, BadInputNamesFileLineAndColumn) {
    const std::string header = "frame,sensor,t_ns,x,y,z,qw,qx,qy,qz\n";
    expect_error("", "x.csv:1: empty file");
    expect_error("frame,sensor,x,y,z\n", "x.csv:1: expected the header");
    expect_error(header + "0,a,0,1,2,3,1,0,0\n", "x.csv:2: expected 10 columns, got 9");
    expect_error(header + "0,a,0,1,2,3,1,0,0,0\nzero,a,0,1,2,3,1,0,0,0\n",
                 "x.csv:3: frame: expected an integer");
    expect_error(header + "0,a,0,1,nan,3,1,0,0,0\n", "x.csv:2: y: expected a finite number");
    expect_error(header + "0,a,0,1,2,3,2,0,0,0\n", "x.csv:2: quaternion is not unit length");
    expect_error(header + "0,,0,1,2,3,1,0,0,0\n", "x.csv:2: sensor: empty name");
}

TEST(PoseCsv, AcceptsCrlfAndBlankLines) {
    std::istringstream in("frame,sensor,t_ns,x,y,z,qw,qx,qy,qz\r\n0,a,5,1,2,3,1,0,0,0\r\n\r\n");
    const auto records = parse_pose_csv(in, "crlf.csv");
    ASSERT_EQ(records.size(), 1u);
    EXPECT_EQ(records[0].t_ns, 5);
}

}  // namespace
}  // namespace lidarfuse::io

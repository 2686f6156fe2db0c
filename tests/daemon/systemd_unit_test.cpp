// The unit file: `systemd-analyze verify` must print nothing, and the offline security
// analysis must rate it well (our threshold: exposure <= 2.0 of 10).
#include <gtest/gtest.h>

#include <filesystem>

#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

std::filesystem::path test_unit() {
    // build/daemon/lidarfused -> build/systemd/test/lidarfused.service (CMake generates it
    // with ExecStart pointing at the built daemon).
    return std::filesystem::path(test::daemon_path()).parent_path().parent_path() / "systemd" /
           "test" / "lidarfused.service";
}

bool have_systemd_analyze() {
    return test::run_command("command -v systemd-analyze", nullptr) == 0;
}

TEST(SystemdUnit, VerifiesWithoutAnyOutput) {
    if (!have_systemd_analyze())
        GTEST_SKIP() << "systemd-analyze not installed (Debian package systemd)";
    ASSERT_TRUE(std::filesystem::exists(test_unit())) << test_unit();
    std::string out;
    const int status = test::run_command("systemd-analyze verify " + test_unit().string(), &out);
    EXPECT_EQ(status, 0) << out;
    EXPECT_EQ(out, "") << "systemd-analyze verify must print nothing";
}

TEST(SystemdUnit, OfflineSecurityExposureIsLow) {
    if (!have_systemd_analyze())
        GTEST_SKIP() << "systemd-analyze not installed (Debian package systemd)";
    std::string out;
    test::run_command("systemd-analyze security --offline=yes " + test_unit().string(), &out);
    const auto level = test::line_after(out, "Overall exposure level for lidarfused.service: ");
    ASSERT_TRUE(level.has_value()) << out;
    EXPECT_LE(std::stod(*level), 2.0) << out;
}

}  // namespace
}  // namespace lidarfuse

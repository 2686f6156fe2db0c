// The Debian package (cmake/LidarfusePackage.cmake, scripts/package.sh): cpack builds it from
// this build tree; its files, control fields and maintainer scripts are checked, lintian
// finds no error, and the packaged executables run from the extracted tree: `lidarfuse sim`
// writes the metadata the example config names, and `lidarfused --check` accepts it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

namespace fs = std::filesystem;

class DebianPackage : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
        return;  // a package of sanitizer builds is not what ships; the release build checks it
#endif
        dir_ = fs::temp_directory_path() / ("lidarfuse_deb_" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        // build/tools/lidarfuse -> build/
        const fs::path build = fs::path(test::tool_path()).parent_path().parent_path();
        ASSERT_EQ(
            test::run_command("cpack -G DEB --config " + (build / "CPackConfig.cmake").string() +
                                  " -B " + dir_.string(),
                              &cpack_output_),
            0)
            << cpack_output_;
        for (const auto& e : fs::directory_iterator(dir_)) {
            if (e.path().extension() == ".deb") deb_ = e.path();
        }
        ASSERT_FALSE(deb_.empty()) << cpack_output_;
        std::string out;
        ASSERT_EQ(test::run_command("dpkg-deb -x " + deb_.string() + " " + (dir_ / "root").string(),
                                    &out),
                  0)
            << out;
    }
    void SetUp() override {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
        GTEST_SKIP()
            << "the package is built and checked in the release build, not the sanitizer ones";
#endif
    }
    static void TearDownTestSuite() {
        if (!dir_.empty()) fs::remove_all(dir_);
    }
    static fs::path dir_, deb_;
    static std::string cpack_output_;
};
fs::path DebianPackage::dir_, DebianPackage::deb_;
std::string DebianPackage::cpack_output_;

TEST_F(DebianPackage, IsNamedAfterItsVersionAndHoldsWhatAStationNeeds) {
    EXPECT_EQ(deb_.filename().string().rfind("lidarfuse_0.1.0_", 0), 0u) << deb_;
    const fs::path root = dir_ / "root";
    for (const char* path :
         {"usr/bin/lidarfuse", "usr/bin/lidarfused", "usr/lib/systemd/system/lidarfused.service",
          "usr/lib/sysctl.d/60-lidarfuse-udp.conf",
          "usr/share/lidarfuse/config/station.example.yaml",
          "usr/share/lidarfuse/config/station.schema.md",
          "usr/share/lidarfuse/config/cyclonedds.xml", "usr/share/doc/lidarfuse/copyright",
          "usr/share/doc/lidarfuse/changelog.gz"}) {
        EXPECT_TRUE(fs::is_regular_file(root / path)) << path;
    }
    // The unit starts the packaged binary, not the build tree's or /usr/local's.
    EXPECT_NE(test::file_text(root / "usr/lib/systemd/system/lidarfused.service")
                  .find("ExecStart=/usr/bin/lidarfused --config /etc/lidarfuse/station.yaml"),
              std::string::npos);
}

TEST_F(DebianPackage, DependsOnTheLibrariesItLinksAndRunsNoMaintainerScripts) {
    std::string fields;
    ASSERT_EQ(
        test::run_command("dpkg-deb -f " + deb_.string() + " Package Version Depends", &fields), 0);
    EXPECT_NE(fields.find("Package: lidarfuse"), std::string::npos) << fields;
    EXPECT_NE(fields.find("Version: 0.1.0"), std::string::npos) << fields;
    // From dpkg-shlibdeps: Cyclone DDS, Ceres' solvers, yaml-cpp, libc.
    for (const char* dep : {"libddsc0debian", "libyaml-cpp0.7", "libc6", "libpcap0.8"}) {
        EXPECT_NE(fields.find(dep), std::string::npos) << dep << " in " << fields;
    }
    // Nothing runs at installation: the unit is neither enabled nor started before the
    // station's config exists.
    const fs::path control = dir_ / "control";
    std::string out;
    ASSERT_EQ(test::run_command("dpkg-deb -e " + deb_.string() + " " + control.string(), &out), 0)
        << out;
    for (const char* script : {"preinst", "postinst", "prerm", "postrm"}) {
        EXPECT_FALSE(fs::exists(control / script)) << script;
    }
}

TEST_F(DebianPackage, LintianFindsNoError) {
    std::string out;
    const int status = test::run_command("lintian --fail-on error " + deb_.string(), &out);
    EXPECT_EQ(status, 0) << out;
    EXPECT_EQ(out.find("\nE: "), std::string::npos) << out;
    EXPECT_NE(out.rfind("E: ", 0), 0u) << out;
}

TEST_F(DebianPackage, PackagedExecutablesRunFromTheExtractedTree) {
    const fs::path root = dir_ / "root";
    const fs::path station = dir_ / "station";
    fs::create_directories(station);
    std::string out;
    ASSERT_EQ(
        test::run_command((root / "usr/bin/lidarfuse").string() +
                              " sim --scenario straight --sensors 2 --seconds 0.1 --quiet --out " +
                              (station / "sim").string(),
                          &out),
        0)
        << out;
    // The example config names north.json and south.json beside it.
    fs::copy_file(root / "usr/share/lidarfuse/config/station.example.yaml",
                  station / "station.yaml");
    fs::copy_file(station / "sim" / "lidar0.json", station / "north.json");
    fs::copy_file(station / "sim" / "lidar1.json", station / "south.json");
    ASSERT_EQ(test::run_command((root / "usr/bin/lidarfused").string() + " --check --config " +
                                    (station / "station.yaml").string(),
                                &out),
              0)
        << out;
    EXPECT_NE(out.find("is valid (2 sensors)"), std::string::npos) << out;
}

}  // namespace
}  // namespace lidarfuse

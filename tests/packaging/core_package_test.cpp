// lidarfuse::core as an outside project sees it: the dev component installed from this build
// tree into a prefix, examples/ configured against it with find_package(lidarfuse) and built,
// and the example run on the real Ouster pair of ../shared/data/real (skipped, visibly, where
// that is absent) and on bad input.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <sstream>
#include <string>

#include "core/common/se3.hpp"
#include "drivers/io/rig_reference.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

namespace fs = std::filesystem;

// A command's status, its output (stdout and stderr) in *out alone.
int run(const std::string& command, std::string* out) {
    out->clear();
    return test::run_command(command, out);
}

// The example's 4 x 4 T_target_source, as it prints it.
Eigen::Isometry3d parse_matrix(const std::string& text) {
    std::istringstream in(text);
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) in >> m(r, c);
    }
    EXPECT_FALSE(in.fail()) << text;
    return Eigen::Isometry3d(m);
}

TEST(CorePackage, AnOutsideProjectBuildsTheExampleAndItRegistersARealPair) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    GTEST_SKIP() << "the installed library of a sanitizer build needs its runtime in the example; "
                    "the release build checks the package";
#endif
    const fs::path build = fs::path(test::tool_path()).parent_path().parent_path();
    test::TempDir dir("core_package");
    const fs::path prefix = dir.path() / "prefix";
    std::string out;
    ASSERT_EQ(
        run("cmake --install " + build.string() + " --component dev --prefix " + prefix.string(),
            &out),
        0)
        << out;
    // The headers under include/lidarfuse/core/<step>/, the archive, the package files; the
    // engine's private header stays inside.
    for (const char* path : {"include/lidarfuse/core/initial/initial_registration.hpp",
                             "include/lidarfuse/core/registration/gicp.hpp",
                             "include/lidarfuse/core/pipeline/fusion_engine.hpp",
                             "lib/liblidarfuse_core.a", "lib/cmake/lidarfuse/lidarfuseConfig.cmake",
                             "lib/cmake/lidarfuse/lidarfuseConfigVersion.cmake"}) {
        EXPECT_TRUE(fs::is_regular_file(prefix / path)) << path << "\n" << out;
    }
    EXPECT_FALSE(fs::exists(prefix / "include/lidarfuse/core/pipeline/fusion_engine_impl.hpp"));
    EXPECT_FALSE(fs::exists(prefix / "bin")) << "the dev component holds no executables";

    const fs::path example = dir.path() / "build-example";
    ASSERT_EQ(run("cmake -S " + (test::source_dir() / "examples").string() + " -B " +
                      example.string() + " -G Ninja -DCMAKE_PREFIX_PATH=" + prefix.string(),
                  &out),
              0)
        << out;
    ASSERT_EQ(run("cmake --build " + example.string(), &out), 0) << out;
    const std::string example_exe = (example / "register_two_clouds").string();

    // Bad input: the file named, exit status 1.
    EXPECT_EQ(run(example_exe + " " + (dir.path() / "absent.pcd").string() + " x", &out), 1);
    EXPECT_NE(out.find("absent.pcd: cannot open"), std::string::npos) << out;

    const auto data = test::data_dir();
    const fs::path rig = data ? *data / "real" / "edgar_ouster_pair" : fs::path();
    if (rig.empty() || !fs::is_directory(rig)) {
        GTEST_SKIP() << "real data edgar_ouster_pair not found (set LIDARFUSE_DATA_DIR to the "
                        "shared data folder): the example was built, not run on a pair";
    }
    // The same pair and bound as CalibrateClouds.RealOusterPairRegistersWithinTheReference:
    // the example's one call runs the same registration as `lidarfuse calibrate`.
    ASSERT_EQ(run(example_exe + " " + (rig / "frontright.pcd").string() + " " +
                      (rig / "frontleft.pcd").string(),
                  &out),
              0)
        << out;
    const Eigen::Isometry3d T = parse_matrix(out);
    const Eigen::Isometry3d reference = io::read_rig_reference(rig / "T_frontright_frontleft.txt");
    EXPECT_LT(core::translation_error_m(T, reference), 0.10) << out;
    EXPECT_LT(core::rotation_error_deg(T, reference), 0.1) << out;
}

}  // namespace
}  // namespace lidarfuse

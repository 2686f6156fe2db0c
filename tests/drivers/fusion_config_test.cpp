// station.yaml's registration and dynamics sections (drivers/station/fusion_config.hpp):
// a bad file is refused naming it and every bad key (the example config is checked
// against lidarfused's defaults in daemon_config_test).
#include "drivers/station/fusion_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "drivers/station/station_config.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::station {
namespace {

using ::testing::HasSubstr;

TEST(FusionConfig, BadFilesAreRefusedNamingTheFileAndEveryKey) {
    test::TempDir dir("fusioncfg");
    const auto refused = [&](const std::string& text) -> std::string {
        std::ofstream(dir.path() / "s.yaml") << text;
        try {
            load_fusion_params(dir.path() / "s.yaml");
        } catch (const ConfigError& e) {
            return e.what();
        }
        ADD_FAILURE() << "accepted:\n" << text;
        return "";
    };
    EXPECT_THAT(
        refused("registration:\n  window_frames: 1\n  windw: 3\ndynamics:\n  attenuation: 2\n"),
        AllOf(HasSubstr("s.yaml"), HasSubstr("registration.window_frames"),
              HasSubstr("registration.windw"), HasSubstr("dynamics.attenuation")));
    EXPECT_THAT(
        refused("registration:\n  covariance_neighbors: 3\n"),
        HasSubstr(
            "registration.covariance_neighbors: expected 0 (by voxel size) or 4..100, got 3"));
    EXPECT_THAT(refused("registration: [1, 2\n"), HasSubstr("not valid YAML"));
    EXPECT_THAT(refused("- a\n- b\n"), HasSubstr("mapping"));
    EXPECT_THAT(refused("registration: 3\n"), HasSubstr("registration"));
    try {
        load_fusion_params(dir.path() / "absent.yaml");
        ADD_FAILURE() << "a missing file was accepted";
    } catch (const ConfigError& e) {
        EXPECT_THAT(e.what(), HasSubstr("absent.yaml"));
    }
    // Absent sections: the defaults.
    std::ofstream(dir.path() / "plain.yaml") << "sensors: []\n";
    EXPECT_EQ(load_fusion_params(dir.path() / "plain.yaml").covariance_neighbors,
              core::FusionParams().covariance_neighbors);
}

// A segment's stations are registered with a tighter correspondence bound than one
// station's sensors, unless the config names one (fusion_config.cpp says why).
TEST(FusionConfig, TheStationsMethodTightensTheCorrespondenceBoundUnlessOneIsGiven) {
    test::TempDir dir("fusioncfg");
    const auto factor = [&](const std::string& text) {
        std::ofstream(dir.path() / "s.yaml") << text;
        return load_fusion_params(dir.path() / "s.yaml").correspondence_factor;
    };
    const double sensors = core::FusionParams().correspondence_factor;
    EXPECT_EQ(factor("sensors: []\n"), sensors);
    EXPECT_EQ(factor("registration:\n  initial_method: features\n"), sensors);
    EXPECT_EQ(factor("registration:\n  initial_method: stations\n"), 0.5);
    EXPECT_EQ(factor("registration:\n  correspondence_factor: 2\n  initial_method: stations\n"),
              2.0);
    EXPECT_EQ(factor("registration:\n  initial_method: features\n  correspondence_factor: 0.8\n"),
              0.8);
    EXPECT_GT(sensors, 0.5);
}

}  // namespace
}  // namespace lidarfuse::station

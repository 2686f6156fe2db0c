#include "drivers/station/station_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "tests/support/test_data.hpp"

namespace lidarfuse::station {
namespace {

using ::testing::HasSubstr;

class StationConfigTest : public ::testing::Test {
protected:
    void SetUp() override {
        for (const char* name : {"a.json", "b.json"}) std::ofstream(dir_.path() / name) << "{}";
    }
    test::TempDir dir_{"station"};
};

TEST_F(StationConfigTest, ParsesSensorsAndResolvesMetadataAgainstTheFileFolder) {
    const auto config = parse_station_config(R"(
station: crossing-7
root: b
sensors:
  - {name: a, udp_port: 7502, metadata: a.json, source_address: 10.0.0.11}
  - {name: b, udp_port: 7504, metadata: b.json, time_offset_ns: -1500, enabled: false}
)",
                                             "station.yaml", dir_.path());
    EXPECT_EQ(config.station, "crossing-7");
    ASSERT_EQ(config.sensors.size(), 2u);
    EXPECT_EQ(config.root_index(), 1u);
    EXPECT_EQ(config.sensors[0].udp_port, 7502);
    EXPECT_EQ(config.sensors[0].metadata, dir_.path() / "a.json");
    EXPECT_EQ(config.sensors[0].source_address.value_or(""), "10.0.0.11");
    EXPECT_EQ(config.sensors[1].time_offset_ns, -1500);
    EXPECT_FALSE(config.sensors[1].enabled);
}

TEST_F(StationConfigTest, RootDefaultsToTheFirstSensor) {
    const auto config = parse_station_config(
        "sensors:\n  - {name: x, udp_port: 1, metadata: a.json}\n", "s.yaml", dir_.path());
    EXPECT_EQ(config.root, "x");
}

// Every problem is reported at once, each with its key path.
TEST_F(StationConfigTest, ReportsEveryProblemWithItsPath) {
    try {
        parse_station_config(R"(
root: nobody
sensers: []
sensors:
  - {name: a, udp_port: 70000, metadata: a.json}
  - {name: a, udp_port: abc, metadata: missing.json, source_address: 300.1.2.3}
  - {udp_port: 7502, metadata: b.json, enabled: maybe, colour: red}
)",
                             "bad.yaml", dir_.path());
        FAIL() << "expected ConfigError";
    } catch (const ConfigError& error) {
        const std::string text = error.what();
        EXPECT_THAT(text, HasSubstr("bad.yaml"));
        EXPECT_THAT(text, HasSubstr("sensers: unknown key"));
        EXPECT_THAT(text, HasSubstr("sensors[0].udp_port: expected an integer in 1..65535"));
        EXPECT_THAT(text, HasSubstr("sensors[1].name: \"a\" is used by another sensor"));
        EXPECT_THAT(text, HasSubstr("sensors[1].udp_port: expected an integer"));
        EXPECT_THAT(text, HasSubstr("sensors[1].metadata: file not found"));
        EXPECT_THAT(text, HasSubstr("sensors[1].source_address: expected an IPv4 address"));
        EXPECT_THAT(text, HasSubstr("sensors[2].name: missing"));
        EXPECT_THAT(text, HasSubstr("sensors[2].enabled: expected true or false"));
        EXPECT_THAT(text, HasSubstr("sensors[2].colour: unknown key"));
        EXPECT_THAT(text, HasSubstr("root: \"nobody\" is not the name"));
        EXPECT_EQ(error.problems().size(), 10u);
    }
}

// The station name is free text, but it must come back unchanged from every file it is
// written to: well-formed UTF-8 is kept (and round-trips), broken UTF-8 and control
// characters are refused naming the key (fuzz finding 5: yaml-cpp rewrote each invalid
// byte as U+FFFD, so the name changed on the way through extrinsics.yaml).
TEST_F(StationConfigTest, StationNameMustBePrintableUtf8) {
    const std::string sensor = "sensors:\n  - {name: a, udp_port: 7502, metadata: a.json}\n";
    for (const std::string good : {"Kreuzung Süd", "路口-3", "A9 km 12.4 (Nord) \xF0\x9F\x9A\x97"}) {
        const auto config = parse_station_config("station: \"" + good + "\"\n" + sensor, "good.yaml", dir_.path());
        EXPECT_EQ(config.station, good);
        const auto back = parse_station_config(to_yaml(config, dir_.path()), "back.yaml", dir_.path());
        EXPECT_EQ(back.station, good);
    }
    const std::string bad_names[] = {
        "samples\xFF\xFF",      // not UTF-8 at all
        "caf\xC3",               // truncated sequence
        "\xC0\xAF",             // overlong '/'
        "\xED\xA0\x80",        // a UTF-16 surrogate
        "two\nlines",            // a control character
        "bell\x07",
        std::string(129, 'x'),  // too long
    };
    for (const std::string& bad : bad_names) {
        std::string yaml = "station: \"";
        for (const char c : bad) {
            if (c == '\n') yaml += "\\n";
            else if (c == '\x07') yaml += "\\a";
            else yaml += c;
        }
        yaml += "\"\n" + sensor;
        try {
            parse_station_config(yaml, "bad.yaml", dir_.path());
            ADD_FAILURE() << "accepted station name of " << bad.size() << " bytes";
        } catch (const ConfigError& error) {
            EXPECT_THAT(error.what(), HasSubstr("bad.yaml"));
            EXPECT_THAT(error.what(), HasSubstr("station: expected 1..128 bytes of printable UTF-8 text"));
            EXPECT_EQ(error.problems().size(), 1u) << error.what();
        }
    }
}

TEST_F(StationConfigTest, SharedPortNeedsDistinctSourceAddresses) {
    EXPECT_THROW(parse_station_config(R"(
sensors:
  - {name: a, udp_port: 7502, metadata: a.json, source_address: 10.0.0.1}
  - {name: b, udp_port: 7502, metadata: b.json, source_address: 10.0.0.1}
)",
                                      "s.yaml", dir_.path()),
                 ConfigError);
    // Without addresses the serial in the packet header tells them apart: accepted here.
    EXPECT_NO_THROW(parse_station_config(R"(
sensors:
  - {name: a, udp_port: 7502, metadata: a.json}
  - {name: b, udp_port: 7502, metadata: b.json}
)",
                                         "s.yaml", dir_.path()));
}

TEST_F(StationConfigTest, BrokenYamlAndMissingFileAreClearErrors) {
    EXPECT_THROW(parse_station_config("sensors: [ {name: a", "s.yaml", dir_.path()), ConfigError);
    EXPECT_THROW(parse_station_config("- just\n- a list\n", "s.yaml", dir_.path()), ConfigError);
    try {
        load_station_config(dir_.path() / "absent.yaml");
        FAIL();
    } catch (const ConfigError& error) {
        EXPECT_THAT(error.what(), HasSubstr("absent.yaml"));
    }
}

TEST_F(StationConfigTest, YamlRoundTrip) {
    StationConfig config;
    config.station = "rt";
    config.root = "b";
    config.sensors.push_back({"a", 7502, dir_.path() / "a.json", std::string("10.1.2.3"), 5, true});
    config.sensors.push_back({"b", 7504, dir_.path() / "b.json", std::nullopt, 0, false});
    const auto yaml = to_yaml(config, dir_.path());
    EXPECT_THAT(yaml, HasSubstr("metadata: a.json"));
    std::ofstream(dir_.path() / "station.yaml") << yaml;
    const auto back = load_station_config(dir_.path() / "station.yaml");
    ASSERT_EQ(back.sensors.size(), 2u);
    EXPECT_EQ(back.station, "rt");
    EXPECT_EQ(back.root, "b");
    for (std::size_t i = 0; i < 2; ++i) {
        EXPECT_EQ(back.sensors[i].name, config.sensors[i].name);
        EXPECT_EQ(back.sensors[i].udp_port, config.sensors[i].udp_port);
        EXPECT_EQ(back.sensors[i].metadata, config.sensors[i].metadata);
        EXPECT_EQ(back.sensors[i].source_address, config.sensors[i].source_address);
        EXPECT_EQ(back.sensors[i].time_offset_ns, config.sensors[i].time_offset_ns);
        EXPECT_EQ(back.sensors[i].enabled, config.sensors[i].enabled);
    }
}

}  // namespace
}  // namespace lidarfuse::station

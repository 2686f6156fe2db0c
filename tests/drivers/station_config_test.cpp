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
    for (const std::string good :
         {"Kreuzung Süd", "路口-3", "A9 km 12.4 (Nord) \xF0\x9F\x9A\x97"}) {
        const auto config =
            parse_station_config("station: \"" + good + "\"\n" + sensor, "good.yaml", dir_.path());
        EXPECT_EQ(config.station, good);
        const auto back =
            parse_station_config(to_yaml(config, dir_.path()), "back.yaml", dir_.path());
        EXPECT_EQ(back.station, good);
    }
    const std::string bad_names[] = {
        "samples\xFF\xFF",                         // not UTF-8 at all
        "caf\xC3",                                 // truncated sequence
        "\xC0\xAF",                                // overlong '/'
        "\xED\xA0\x80",                            // a UTF-16 surrogate
        "two\nlines",                              // a control character
        "bell\x07",        std::string(129, 'x'),  // too long
    };
    for (const std::string& bad : bad_names) {
        std::string yaml = "station: \"";
        for (const char c : bad) {
            if (c == '\n')
                yaml += "\\n";
            else if (c == '\x07')
                yaml += "\\a";
            else
                yaml += c;
        }
        yaml += "\"\n" + sensor;
        try {
            parse_station_config(yaml, "bad.yaml", dir_.path());
            ADD_FAILURE() << "accepted station name of " << bad.size() << " bytes";
        } catch (const ConfigError& error) {
            EXPECT_THAT(error.what(), HasSubstr("bad.yaml"));
            EXPECT_THAT(error.what(),
                        HasSubstr("station: expected 1..128 bytes of printable UTF-8 text"));
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

TEST_F(StationConfigTest, SensorsByHostnameWithAndWithoutConfiguration) {
    const auto config = parse_station_config(R"(
sensors:
  - {name: a, udp_port: 7502, hostname: os-122239000672.local}
  - {name: b, udp_port: 7504, hostname: 10.5.6.12, http_port: 8080, configure: true}
  - name: c
    udp_port: 7506
    hostname: 10.5.6.13
    configure: {udp_dest: 10.5.6.2, lidar_mode: 1024x20, timestamp_mode: TIME_FROM_PTP_1588}
)",
                                             "station.yaml", dir_.path());
    ASSERT_EQ(config.sensors.size(), 3u);
    EXPECT_EQ(config.sensors[0].hostname.value_or(""), "os-122239000672.local");
    EXPECT_TRUE(config.sensors[0].metadata.empty());
    EXPECT_EQ(config.sensors[0].http_port, 80);
    EXPECT_FALSE(config.sensors[0].configure.enabled);
    EXPECT_EQ(config.sensors[1].http_port, 8080);
    EXPECT_TRUE(config.sensors[1].configure.enabled);
    EXPECT_FALSE(config.sensors[1].configure.udp_dest);
    const auto& c = config.sensors[2].configure;
    EXPECT_TRUE(c.enabled);
    EXPECT_EQ(c.udp_dest.value_or(""), "10.5.6.2");
    EXPECT_EQ(c.lidar_mode.value_or(""), "1024x20");
    EXPECT_EQ(c.timestamp_mode.value_or(""), "TIME_FROM_PTP_1588");
    // ... and back through the YAML writer.
    const auto back = parse_station_config(to_yaml(config, dir_.path()), "back.yaml", dir_.path());
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(back.sensors[i].hostname, config.sensors[i].hostname);
        EXPECT_EQ(back.sensors[i].http_port, config.sensors[i].http_port);
        EXPECT_EQ(back.sensors[i].configure.enabled, config.sensors[i].configure.enabled);
        EXPECT_EQ(back.sensors[i].configure.udp_dest, config.sensors[i].configure.udp_dest);
        EXPECT_EQ(back.sensors[i].configure.lidar_mode, config.sensors[i].configure.lidar_mode);
        EXPECT_EQ(back.sensors[i].configure.timestamp_mode,
                  config.sensors[i].configure.timestamp_mode);
    }
}

TEST_F(StationConfigTest, MetadataSourceProblemsAreEachNamed) {
    try {
        parse_station_config(R"(
sensors:
  - {name: both, udp_port: 7502, metadata: a.json, hostname: 10.0.0.1}
  - {name: neither, udp_port: 7504}
  - {name: url, udp_port: 7506, hostname: "http://10.0.0.3/"}
  - {name: file, udp_port: 7508, metadata: b.json, configure: true, http_port: 8080}
  - {name: mode, udp_port: 7510, hostname: 10.0.0.5, configure: {lidar_mode: 1024x30, colour: red}}
  - {name: dest, udp_port: 7512, hostname: 10.0.0.6, configure: {udp_dest: nowhere, timestamp_mode: GPS}}
  - {name: port, udp_port: 7514, hostname: 10.0.0.7, http_port: 0, configure: maybe}
)",
                             "hosts.yaml", dir_.path());
        FAIL() << "expected ConfigError";
    } catch (const ConfigError& error) {
        const std::string text = error.what();
        EXPECT_THAT(text, HasSubstr("sensors[0]: expected exactly one of metadata (a JSON file), "
                                    "hostname (the sensor's HTTP API) and source (clouds from "
                                    "DDS), got metadata and hostname"));
        EXPECT_THAT(text, HasSubstr("sensors[1]: expected exactly one of metadata"));
        EXPECT_THAT(text, HasSubstr("got none"));
        EXPECT_THAT(text, HasSubstr("sensors[2].hostname: expected a host name or IPv4 address, "
                                    "got \"http://10.0.0.3/\""));
        EXPECT_THAT(text, HasSubstr("sensors[3]: http_port and configure need hostname"));
        EXPECT_THAT(text, HasSubstr("sensors[4].configure.lidar_mode: expected 512x10, 512x20"));
        EXPECT_THAT(text, HasSubstr("sensors[4].configure.colour: unknown key"));
        EXPECT_THAT(text, HasSubstr("sensors[5].configure.udp_dest: expected an IPv4 address"));
        EXPECT_THAT(text, HasSubstr("sensors[5].configure.timestamp_mode: expected"));
        EXPECT_THAT(text, HasSubstr("sensors[6].http_port: expected an integer in 1..65535"));
        EXPECT_THAT(text, HasSubstr("sensors[6].configure: expected true or false"));
        EXPECT_EQ(error.problems().size(), 10u) << text;
    }
}

// A sensor whose clouds come from DDS: no port, no metadata; its topic and domain read,
// written back, and used by one sensor only.
TEST_F(StationConfigTest, SensorsFromDdsTopics) {
    const auto config = parse_station_config(R"(
sensors:
  - {name: station0, source: {dds: {topic: rt/station0/lidarfuse/points, domain_id: 7}}}
  - {name: station1, source: {dds: {topic: rt/station1/lidarfuse/points}}, time_offset_ns: -5}
  - {name: lidar, udp_port: 7502, metadata: a.json}
)",
                                             "segment.yaml", dir_.path());
    ASSERT_EQ(config.sensors.size(), 3u);
    ASSERT_TRUE(config.sensors[0].dds);
    EXPECT_EQ(config.sensors[0].dds->topic, "rt/station0/lidarfuse/points");
    EXPECT_EQ(config.sensors[0].dds->domain_id, 7);
    EXPECT_EQ(config.sensors[0].udp_port, 0);
    EXPECT_TRUE(config.sensors[0].metadata.empty());
    ASSERT_TRUE(config.sensors[1].dds);
    EXPECT_EQ(config.sensors[1].dds->domain_id, 0);
    EXPECT_EQ(config.sensors[1].time_offset_ns, -5);
    EXPECT_FALSE(config.sensors[2].dds);
    const auto back = parse_station_config(to_yaml(config, dir_.path()), "back.yaml", dir_.path());
    ASSERT_EQ(back.sensors.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
        ASSERT_EQ(back.sensors[i].dds.has_value(), config.sensors[i].dds.has_value());
        if (!config.sensors[i].dds) continue;
        EXPECT_EQ(back.sensors[i].dds->topic, config.sensors[i].dds->topic);
        EXPECT_EQ(back.sensors[i].dds->domain_id, config.sensors[i].dds->domain_id);
    }
    EXPECT_EQ(back.sensors[2].udp_port, 7502);
}

TEST_F(StationConfigTest, DdsSourceProblemsAreEachNamed) {
    try {
        parse_station_config(R"(
sensors:
  - {name: both, metadata: a.json, source: {dds: {topic: rt/a/points}}}
  - {name: port, udp_port: 7502, source: {dds: {topic: rt/b/points}}}
  - {name: topic, source: {dds: {topic: "rt//points"}}}
  - {name: domain, source: {dds: {topic: rt/c/points, domain_id: 233}}}
  - {name: kind, source: {udp: {port: 7502}}}
  - {name: key, source: {dds: {topic: rt/d/points, qos: fast}}}
  - {name: twice, source: {dds: {topic: rt/d/points}}}
  - {name: notopic, source: {dds: {domain_id: 1}}}
)",
                             "dds.yaml", dir_.path());
        FAIL() << "expected ConfigError";
    } catch (const ConfigError& error) {
        const std::string text = error.what();
        EXPECT_THAT(text, HasSubstr("sensors[0]: expected exactly one of metadata (a JSON file), "
                                    "hostname (the sensor's HTTP API) and source (clouds from "
                                    "DDS), got metadata and source"));
        EXPECT_THAT(text, HasSubstr("sensors[1]: udp_port and source_address are for Ouster "
                                    "packets, not for a source"));
        EXPECT_THAT(text, HasSubstr("sensors[2].source.dds.topic: expected a DDS topic name"));
        EXPECT_THAT(text, HasSubstr("got \"rt//points\""));
        EXPECT_THAT(text, HasSubstr("sensors[3].source.dds.domain_id: expected an integer in "
                                    "0..232"));
        EXPECT_THAT(text, HasSubstr("sensors[4].source: expected a mapping {dds: {topic: "
                                    "rt/<ns>/points, domain_id: N}}"));
        EXPECT_THAT(text, HasSubstr("sensors[5].source.dds.qos: unknown key"));
        EXPECT_THAT(text, HasSubstr("sensors[6].source.dds: topic rt/d/points in domain 0 is "
                                    "used by another sensor"));
        EXPECT_THAT(text, HasSubstr("sensors[7].source.dds.topic"));
        EXPECT_EQ(error.problems().size(), 8u) << text;
    }
}

TEST_F(StationConfigTest, YamlRoundTrip) {
    StationConfig config;
    config.station = "rt";
    config.root = "b";
    config.sensors.push_back({"a",
                              7502,
                              dir_.path() / "a.json",
                              std::string("10.1.2.3"),
                              5,
                              true,
                              std::nullopt,
                              80,
                              {},
                              std::nullopt});
    config.sensors.push_back({"b",
                              7504,
                              dir_.path() / "b.json",
                              std::nullopt,
                              0,
                              false,
                              std::nullopt,
                              80,
                              {},
                              std::nullopt});
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

// libFuzzer harness: station.yaml text -> the station section (sensors, ports, metadata
// paths, source addresses, root) through load-time validation, with the YamlReader that
// the daemon's other sections use too.
//
// Not covered here: daemon/daemon_config.cpp's sections (network, sync, registration,
// output, health). Its DaemonConfig defaults come from core's registration parameters, so
// fuzzing it would mean building all of core with clang in the fuzz folder (minutes on
// the CI machine); the same YamlReader calls are exercised here.
//
// Metadata paths resolve against $LIDARFUSE_FUZZ_BASE_DIR when set (the seed corpus names
// the sample metadata files, so valid configs are reachable), else the current folder.
// Contract checked besides memory safety (station_config.hpp): any text either parses or
// throws ConfigError listing at least one problem; no other exception escapes; an
// accepted config has sensors with distinct names, ports in 1..65535, a root among them,
// and survives to_yaml() -> parse unchanged.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>

#include "drivers/station/station_config.hpp"
#include "fuzz/fuzz_input.hpp"

using namespace lidarfuse;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const std::filesystem::path base_dir = [] {
        const char* dir = std::getenv("LIDARFUSE_FUZZ_BASE_DIR");
        return std::filesystem::absolute(dir ? dir : ".");
    }();
    const std::string text(reinterpret_cast<const char*>(data), size);
    station::StationConfig config;
    try {
        config = station::parse_station_config(text, "fuzz.yaml", base_dir);
    } catch (const station::ConfigError& error) {
        if (error.problems().empty()) fuzz::invariant_failed("ConfigError without a problem");
        return 0;
    }
    const auto& sensors = config.sensors;
    if (sensors.empty()) fuzz::invariant_failed("accepted a station without sensors");
    if (sensors[config.root_index()].name != config.root)
        fuzz::invariant_failed("root not a sensor");
    std::set<std::string> names;
    for (const auto& s : sensors) {
        if (!names.insert(s.name).second) fuzz::invariant_failed("duplicate sensor name accepted");
        if (s.udp_port == 0) fuzz::invariant_failed("port 0 accepted");
    }
    station::StationConfig again;
    try {
        again = station::parse_station_config(station::to_yaml(config, base_dir),
                                              "fuzz-rewritten.yaml", base_dir);
    } catch (const station::ConfigError& error) {
        std::fprintf(stderr, "%s\n", error.what());
        fuzz::invariant_failed("to_yaml() output does not parse");
    }
    if (again.sensors.size() != sensors.size() || again.root != config.root ||
        again.station != config.station) {
        fuzz::invariant_failed("to_yaml() round trip differs");
    }
    for (std::size_t i = 0; i < sensors.size(); ++i) {
        const auto& a = sensors[i];
        const auto& b = again.sensors[i];
        if (a.name != b.name || a.udp_port != b.udp_port || a.metadata != b.metadata ||
            a.source_address != b.source_address || a.time_offset_ns != b.time_offset_ns ||
            a.enabled != b.enabled) {
            fuzz::invariant_failed("to_yaml() round trip changes a sensor");
        }
    }
    return 0;
}

#pragma once
// Reads typed values out of YAML nodes while collecting every problem with its key path,
// so a config loader can report all of them at once (STYLE.md: errors at start-up list
// every problem). Used by station.yaml and the daemon's sections.

#include <yaml-cpp/yaml.h>

#include <optional>
#include <set>
#include <string>
#include <vector>

namespace lidarfuse::station {

class YamlReader {
public:
    std::vector<std::string> problems;

    std::optional<std::string> string(const YAML::Node& node, const std::string& path,
                                      bool required);
    std::optional<long long> integer(const YAML::Node& node, const std::string& path, long long min,
                                     long long max, bool required);
    std::optional<double> number(const YAML::Node& node, const std::string& path, double min,
                                 double max, bool required);
    std::optional<bool> boolean(const YAML::Node& node, const std::string& path);
    // A tf2 frame id (valid_frame_id below), optional; anything else reported as
    // `path: expected 1..128 characters of [A-Za-z0-9_./-], ...`.
    std::optional<std::string> frame_id(const YAML::Node& node, const std::string& path);
    // One of `options` (at least two): its index; anything else reported as
    // `path: expected a, b or c, got "x"`.
    std::optional<std::size_t> choice(const YAML::Node& node, const std::string& path,
                                      const std::vector<std::string>& options);
    // Reports keys of `map` that are not in `allowed` (typos), as `path.key`.
    void only_keys(const YAML::Node& map, const std::string& path,
                   const std::set<std::string>& allowed);
    // True when `node` is absent or a mapping; reports it otherwise.
    bool optional_map(const YAML::Node& node, const std::string& path);

    static std::string describe(const YAML::Node& node);
};

// A tf2 frame id: 1..128 characters of [A-Za-z0-9_./-], no leading '/' (tf2 refuses it).
bool valid_frame_id(const std::string& frame);

// The YAML document of a config file's text, which must be a mapping at the top level;
// ConfigError (station_config.hpp) naming `source_name` otherwise.
YAML::Node load_config_document(const std::string& yaml_text, const std::string& source_name);

// Stores a value that was read (and is valid) into the config field it belongs to.
template <typename T, typename U>
void set_if(const std::optional<U>& value, T* target) {
    if (value) *target = static_cast<T>(*value);
}

}  // namespace lidarfuse::station

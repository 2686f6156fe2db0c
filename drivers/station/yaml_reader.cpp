#include "drivers/station/yaml_reader.hpp"

#include <cmath>
#include <sstream>

#include "drivers/station/station_config.hpp"

namespace lidarfuse::station {

YAML::Node load_config_document(const std::string& yaml_text, const std::string& source_name) {
    YAML::Node doc;
    try {
        doc = YAML::Load(yaml_text);
    } catch (const YAML::Exception& error) {
        throw ConfigError(source_name, {"not valid YAML: " + std::string(error.what())});
    }
    if (!doc.IsMap()) throw ConfigError(source_name, {"(top level): expected a mapping"});
    return doc;
}

std::optional<std::string> YamlReader::string(const YAML::Node& node, const std::string& path,
                                              bool required) {
    if (!node) {
        if (required) problems.push_back(path + ": missing (expected a string)");
        return std::nullopt;
    }
    if (!node.IsScalar() || node.Scalar().empty()) {
        problems.push_back(path + ": expected a non-empty string");
        return std::nullopt;
    }
    return node.Scalar();
}

bool valid_frame_id(const std::string& frame) {
    if (frame.empty() || frame.size() > 128 || frame.front() == '/') return false;
    for (const char c : frame) {
        const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                        (c >= '0' && c <= '9') || c == '_' || c == '.' || c == '/' || c == '-';
        if (!ok) return false;
    }
    return true;
}

std::optional<std::string> YamlReader::frame_id(const YAML::Node& node, const std::string& path) {
    auto frame = string(node, path, false);
    if (frame && !valid_frame_id(*frame)) {
        problems.push_back(path +
                           ": expected 1..128 characters of [A-Za-z0-9_./-], not starting with "
                           "'/' (tf2 refuses a leading slash), got \"" +
                           *frame + "\"");
        return std::nullopt;
    }
    return frame;
}

std::optional<long long> YamlReader::integer(const YAML::Node& node, const std::string& path,
                                             long long min, long long max, bool required) {
    if (!node) {
        if (required) problems.push_back(path + ": missing (expected an integer)");
        return std::nullopt;
    }
    long long value = 0;
    if (!node.IsScalar() || !YAML::convert<long long>::decode(node, value) || value < min ||
        value > max) {
        problems.push_back(path + ": expected an integer in " + std::to_string(min) + ".." +
                           std::to_string(max) + ", got " + describe(node));
        return std::nullopt;
    }
    return value;
}

std::optional<double> YamlReader::number(const YAML::Node& node, const std::string& path,
                                         double min, double max, bool required) {
    if (!node) {
        if (required) problems.push_back(path + ": missing (expected a number)");
        return std::nullopt;
    }
    double value = 0;
    if (!node.IsScalar() || !YAML::convert<double>::decode(node, value) || !std::isfinite(value) ||
        value < min || value > max) {
        std::ostringstream range;
        range << min << ".." << max;
        problems.push_back(path + ": expected a number in " + range.str() + ", got " +
                           describe(node));
        return std::nullopt;
    }
    return value;
}

std::optional<std::size_t> YamlReader::choice(const YAML::Node& node, const std::string& path,
                                              const std::vector<std::string>& options) {
    const auto text = string(node, path, false);
    if (!text) return std::nullopt;
    for (std::size_t i = 0; i < options.size(); ++i) {
        if (*text == options[i]) return i;
    }
    std::string expected;
    for (std::size_t i = 0; i < options.size(); ++i) {
        expected += (i == 0 ? "" : i + 1 == options.size() ? " or " : ", ") + options[i];
    }
    problems.push_back(path + ": expected " + expected + ", got \"" + *text + "\"");
    return std::nullopt;
}

std::optional<bool> YamlReader::boolean(const YAML::Node& node, const std::string& path) {
    if (!node) return std::nullopt;
    bool value = false;
    if (!node.IsScalar() || !YAML::convert<bool>::decode(node, value)) {
        problems.push_back(path + ": expected true or false, got " + describe(node));
        return std::nullopt;
    }
    return value;
}

void YamlReader::only_keys(const YAML::Node& map, const std::string& path,
                           const std::set<std::string>& allowed) {
    for (const auto& item : map) {
        const auto key = item.first.Scalar();
        if (!allowed.count(key)) {
            problems.push_back((path.empty() ? "" : path + ".") + key + ": unknown key (a typo?)");
        }
    }
}

bool YamlReader::optional_map(const YAML::Node& node, const std::string& path) {
    if (!node || node.IsMap()) return true;
    problems.push_back(path + ": expected a mapping, got " + describe(node));
    return false;
}

std::string YamlReader::describe(const YAML::Node& node) {
    if (node.IsScalar()) return "\"" + node.Scalar() + "\"";
    if (node.IsSequence()) return "a list";
    if (node.IsMap()) return "a mapping";
    return "nothing";
}

}  // namespace lidarfuse::station

#include "drivers/station/station_config.hpp"

#include <arpa/inet.h>
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <fstream>
#include <set>
#include <sstream>

#include "drivers/station/yaml_reader.hpp"

namespace lidarfuse::station {

namespace {

std::string join_problems(const std::string& source, const std::vector<std::string>& problems) {
    std::ostringstream out;
    out << source << ": " << problems.size() << " problem" << (problems.size() == 1 ? "" : "s")
        << " in the station config";
    for (const auto& p : problems) out << "\n  " << p;
    return out.str();
}

// Sections owned by later stages; accepted here and validated by their owners.
const std::set<std::string> kTopLevelKeys = {"station", "root",         "sensors",  "sync",
                                             "network", "registration", "dynamics", "output",
                                             "dds",     "logging",      "health",   "world"};
const std::set<std::string> kSensorKeys = {
    "name",      "udp_port",       "metadata",       "hostname", "http_port",
    "configure", "source_address", "time_offset_ns", "enabled",  "source"};
const std::set<std::string> kSourceKeys = {"dds"};
const std::set<std::string> kDdsSourceKeys = {"topic", "domain_id", "frame_id"};
const std::set<std::string> kConfigureKeys = {"udp_dest", "lidar_mode", "timestamp_mode"};

bool ascii_alnum(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
}

// A sensor name ends up unquoted in poses.csv, as a key in extrinsics.yaml and as a ROS tf
// frame id: a comma, newline, colon or non-ASCII byte would corrupt those files.
bool valid_sensor_name(const std::string& name) {
    if (name.empty() || name.size() > 64) return false;
    for (const char c : name) {
        if (!ascii_alnum(c) && c != '_' && c != '.' && c != '-') return false;
    }
    return true;
}

// The station name is free text for logs, diagnostics and extrinsics.yaml, but it must
// survive those round trips: 1..128 bytes of well-formed UTF-8 (no overlong forms, no
// surrogates) without control characters. yaml-cpp turns each invalid byte into U+FFFD,
// so a name with one would come back different (fuzz finding 5).
bool valid_station_name(const std::string& name) {
    if (name.empty() || name.size() > 128) return false;
    std::size_t i = 0;
    while (i < name.size()) {
        const auto c = static_cast<unsigned char>(name[i]);
        if (c < 0x80) {
            if (c < 0x20 || c == 0x7F) return false;
            ++i;
            continue;
        }
        std::size_t length = 0;
        std::uint32_t code = 0;
        if (c >= 0xC2 && c <= 0xDF) {
            length = 2;
            code = c & 0x1Fu;
        } else if (c >= 0xE0 && c <= 0xEF) {
            length = 3;
            code = c & 0x0Fu;
        } else if (c >= 0xF0 && c <= 0xF4) {
            length = 4;
            code = c & 0x07u;
        } else {
            return false;  // a continuation byte first, an overlong 0xC0/0xC1 lead, or > U+10FFFF
        }
        if (i + length > name.size()) return false;
        for (std::size_t k = 1; k < length; ++k) {
            const auto next = static_cast<unsigned char>(name[i + k]);
            if ((next & 0xC0u) != 0x80u) return false;
            code = (code << 6) | (next & 0x3Fu);
        }
        const bool overlong = (length == 3 && code < 0x800) || (length == 4 && code < 0x10000);
        if (overlong || (code >= 0xD800 && code <= 0xDFFF) || code > 0x10FFFF ||
            (code >= 0x80 && code < 0xA0)) {
            return false;  // the last: C1 control characters
        }
        i += length;
    }
    return true;
}

// The name as it can go into an error message: non-printable bytes as \xNN, at most 80.
std::string printable(const std::string& text) {
    std::string out;
    for (std::size_t i = 0; i < text.size() && out.size() < 80; ++i) {
        const auto c = static_cast<unsigned char>(text[i]);
        if (c >= 0x20 && c < 0x7F) {
            out.push_back(static_cast<char>(c));
        } else {
            const char* hex = "0123456789abcdef";
            out += "\\x";
            out.push_back(hex[c >> 4]);
            out.push_back(hex[c & 15]);
        }
    }
    return out;
}

// hostname: a DNS name (letters, digits, '-', '.') or a dotted quad; nothing that would
// change the meaning of the URL built from it.
bool valid_hostname(const std::string& host) {
    if (host.empty() || host.size() > 253) return false;
    for (const char c : host) {
        const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                        (c >= '0' && c <= '9') || c == '-' || c == '.';
        if (!ok) return false;
    }
    return host.front() != '-' && host.front() != '.';
}

// An optional dotted-quad IPv4 address: its text when valid, else nullopt (and the problem).
std::optional<std::string> ipv4_text(const YAML::Node& node, const std::string& path,
                                     YamlReader* r) {
    auto text = r->string(node, path, false);
    in_addr parsed{};
    if (text && ::inet_pton(AF_INET, text->c_str(), &parsed) != 1) {
        r->problems.push_back(path + ": expected an IPv4 address, got \"" + *text + "\"");
        return std::nullopt;
    }
    return text;
}

// sensors[i].configure: `true`/`false`, or a mapping of the parameters to set (enabled).
void read_configure(const YAML::Node& node, const std::string& path, YamlReader* r,
                    SensorConfigure* out) {
    if (!node) return;
    if (!node.IsMap()) {
        if (auto b = r->boolean(node, path)) out->enabled = *b;
        return;
    }
    r->only_keys(node, path, kConfigureKeys);
    out->enabled = true;
    out->udp_dest = ipv4_text(node["udp_dest"], path + ".udp_dest", r);
    static const std::vector<std::string> kModes = {"512x10",  "512x20",  "1024x10",
                                                    "1024x20", "2048x10", "4096x5"};
    static const std::vector<std::string> kTimestampModes = {
        "TIME_FROM_INTERNAL_OSC", "TIME_FROM_SYNC_PULSE_IN", "TIME_FROM_PTP_1588"};
    if (auto m = r->choice(node["lidar_mode"], path + ".lidar_mode", kModes)) {
        out->lidar_mode = kModes[*m];
    }
    if (auto t = r->choice(node["timestamp_mode"], path + ".timestamp_mode", kTimestampModes)) {
        out->timestamp_mode = kTimestampModes[*t];
    }
}

// A DDS topic name as Cyclone and ROS 2 accept it on the wire (rt/<namespace>/<name>):
// 1..255 characters of [A-Za-z0-9_/], no empty segment, not starting with a digit.
bool valid_dds_topic(const std::string& topic) {
    if (topic.empty() || topic.size() > 255 || topic.front() == '/' || topic.back() == '/' ||
        (topic.front() >= '0' && topic.front() <= '9') || topic.find("//") != std::string::npos) {
        return false;
    }
    for (const char c : topic) {
        if (!ascii_alnum(c) && c != '_' && c != '/') return false;
    }
    return true;
}

// sensors[i].source: {dds: {topic, domain_id, frame_id}}.
void read_source(const YAML::Node& node, const std::string& path, YamlReader* r,
                 SensorConfig* sensor) {
    if (!node.IsMap() || !node["dds"].IsDefined() || !node["dds"].IsMap()) {
        r->problems.push_back(path +
                              ": expected a mapping {dds: {topic: rt/<ns>/points, "
                              "domain_id: N}}");
        return;
    }
    r->only_keys(node, path, kSourceKeys);
    const YAML::Node dds = node["dds"];
    r->only_keys(dds, path + ".dds", kDdsSourceKeys);
    DdsSource source;
    if (auto t = r->string(dds["topic"], path + ".dds.topic", true)) {
        source.topic = *t;
        if (!valid_dds_topic(*t)) {
            r->problems.push_back(path +
                                  ".dds.topic: expected a DDS topic name (1..255 of "
                                  "[A-Za-z0-9_/], e.g. rt/station1/points), got \"" +
                                  printable(*t) + "\"");
        }
    }
    if (auto d = r->integer(dds["domain_id"], path + ".dds.domain_id", 0, 232, false)) {
        source.domain_id = static_cast<int>(*d);
    }
    source.frame_id = r->frame_id(dds["frame_id"], path + ".dds.frame_id");
    sensor->dds = source;
}

// Exactly one of sensors[i].metadata (a file that exists), sensors[i].hostname and
// sensors[i].source.
void read_metadata_source(const YAML::Node& node, const std::string& path,
                          const std::filesystem::path& base_dir, YamlReader* r,
                          SensorConfig* sensor) {
    const bool has_host = node["hostname"].IsDefined(), has_source = node["source"].IsDefined();
    std::vector<std::string> given;
    for (const char* key : {"metadata", "hostname", "source"}) {
        if (node[key].IsDefined()) given.push_back(key);
    }
    if (given.size() != 1) {
        std::string got = given.empty() ? "none" : given[0];
        for (std::size_t k = 1; k < given.size(); ++k) got += " and " + given[k];
        r->problems.push_back(path +
                              ": expected exactly one of metadata (a JSON file), "
                              "hostname (the sensor's HTTP API) and source (clouds from DDS), "
                              "got " +
                              got);
    }
    if (auto m = r->string(node["metadata"], path + ".metadata", false)) {
        std::filesystem::path file = *m;
        sensor->metadata = file.is_absolute() ? file : (base_dir / file).lexically_normal();
        std::error_code ec;
        if (!std::filesystem::is_regular_file(sensor->metadata, ec)) {
            r->problems.push_back(path + ".metadata: file not found: " + sensor->metadata.string());
        }
    }
    if (auto h = r->string(node["hostname"], path + ".hostname", false)) {
        if (!valid_hostname(*h)) {
            r->problems.push_back(path + ".hostname: expected a host name or IPv4 address, got \"" +
                                  printable(*h) + "\"");
        }
        sensor->hostname = *h;
    }
    if (auto p = r->integer(node["http_port"], path + ".http_port", 1, 65535, false)) {
        sensor->http_port = static_cast<int>(*p);
    }
    read_configure(node["configure"], path + ".configure", r, &sensor->configure);
    if (!has_host && (node["http_port"].IsDefined() || node["configure"].IsDefined())) {
        r->problems.push_back(path + ": http_port and configure need hostname");
    }
    if (has_source) read_source(node["source"], path + ".source", r, sensor);
    if (has_source && (node["udp_port"].IsDefined() || node["source_address"].IsDefined())) {
        r->problems.push_back(path +
                              ": udp_port and source_address are for Ouster packets, "
                              "not for a source");
    }
}

}  // namespace

ConfigError::ConfigError(const std::string& source, std::vector<std::string> problems)
    : std::runtime_error(join_problems(source, problems)), problems_(std::move(problems)) {}

std::size_t StationConfig::root_index() const {
    for (std::size_t i = 0; i < sensors.size(); ++i) {
        if (sensors[i].name == root) return i;
    }
    return 0;
}

namespace {

void read_station_name(YamlReader& r, const YAML::Node& doc, StationConfig* config) {
    if (auto s = r.string(doc["station"], "station", false)) {
        if (valid_station_name(*s)) {
            config->station = *s;
        } else {
            r.problems.push_back("station: expected 1..128 bytes of printable UTF-8 text, got \"" +
                                 printable(*s) + "\"");
        }
    }
}

// What the sensors seen so far use, to refuse a second sensor with the same name or endpoint.
struct SensorsSeen {
    std::set<std::string> names;
    std::set<std::pair<std::uint16_t, std::string>> endpoints;  // udp port, source address
    std::set<std::string> dds_topics;                           // "domain/topic"
};

void read_sensor_name(YamlReader& r, const YAML::Node& node, const std::string& path,
                      SensorsSeen* seen, SensorConfig* sensor) {
    if (auto s = r.string(node["name"], path + ".name", true)) {
        sensor->name = *s;
        if (!valid_sensor_name(*s)) {
            r.problems.push_back(path +
                                 ".name: expected 1..64 characters of [A-Za-z0-9_.-] (it names "
                                 "poses.csv rows, extrinsics.yaml keys and tf frames), got \"" +
                                 printable(*s) + "\"");
        }
        if (!seen->names.insert(*s).second) {
            r.problems.push_back(path + ".name: \"" + *s + "\" is used by another sensor");
        }
    }
}

// One entry of `sensors` (a mapping, checked by the caller).
SensorConfig read_sensor(YamlReader& r, const YAML::Node& node, const std::string& path,
                         const std::filesystem::path& base_dir, SensorsSeen* seen) {
    r.only_keys(node, path, kSensorKeys);
    SensorConfig sensor;
    read_sensor_name(r, node, path, seen, &sensor);
    const bool packets = !node["source"].IsDefined();  // Ouster UDP, not a DDS source
    if (auto p = r.integer(node["udp_port"], path + ".udp_port", 1, 65535, packets)) {
        sensor.udp_port = static_cast<std::uint16_t>(*p);
    }
    read_metadata_source(node, path, base_dir, &r, &sensor);
    sensor.source_address = ipv4_text(node["source_address"], path + ".source_address", &r);
    if (auto t = r.integer(node["time_offset_ns"], path + ".time_offset_ns", -3600LL * 1000000000LL,
                           3600LL * 1000000000LL, false)) {
        sensor.time_offset_ns = *t;
    }
    if (auto e = r.boolean(node["enabled"], path + ".enabled")) sensor.enabled = *e;
    // Two sensors on one port are fine only when their source addresses tell them
    // apart (or, for non-legacy profiles, their serials; checked against metadata).
    const auto endpoint = std::make_pair(sensor.udp_port, sensor.source_address.value_or("*"));
    if (sensor.udp_port != 0 && !seen->endpoints.insert(endpoint).second &&
        endpoint.second != "*") {
        r.problems.push_back(path + ".source_address: port " + std::to_string(sensor.udp_port) +
                             " and address " + endpoint.second + " are used by another sensor");
    }
    if (sensor.dds) {
        const std::string key = std::to_string(sensor.dds->domain_id) + "/" + sensor.dds->topic;
        if (!seen->dds_topics.insert(key).second) {
            r.problems.push_back(path + ".source.dds: topic " + sensor.dds->topic + " in domain " +
                                 std::to_string(sensor.dds->domain_id) +
                                 " is used by another sensor");
        }
    }
    return sensor;
}

void read_sensors(YamlReader& r, const YAML::Node& doc, const std::filesystem::path& base_dir,
                  StationConfig* config) {
    const YAML::Node sensors = doc["sensors"];
    if (!sensors || !sensors.IsSequence() || sensors.size() == 0) {
        r.problems.push_back("sensors: expected a non-empty list of sensors");
        return;
    }
    SensorsSeen seen;
    for (std::size_t i = 0; i < sensors.size(); ++i) {
        const std::string path = "sensors[" + std::to_string(i) + "]";
        const YAML::Node node = sensors[i];
        if (!node.IsMap()) {
            r.problems.push_back(path + ": expected a mapping");
            continue;
        }
        config->sensors.push_back(read_sensor(r, node, path, base_dir, &seen));
    }
}

// root: a configured sensor's name; the first sensor when not given.
void read_root(YamlReader& r, const YAML::Node& doc, StationConfig* config) {
    if (auto root = r.string(doc["root"], "root", false)) {
        config->root = *root;
        bool found = false;
        for (const auto& s : config->sensors) found = found || s.name == *root;
        if (!found && !config->sensors.empty()) {
            r.problems.push_back("root: \"" + *root + "\" is not the name of a configured sensor");
        }
    } else if (!config->sensors.empty()) {
        config->root = config->sensors.front().name;
    }
}

}  // namespace

StationConfig parse_station_config(const std::string& yaml_text, const std::string& source_name,
                                   const std::filesystem::path& base_dir) {
    const YAML::Node doc = load_config_document(yaml_text, source_name);
    YamlReader r;
    StationConfig config;
    r.only_keys(doc, "", kTopLevelKeys);
    read_station_name(r, doc, &config);
    read_sensors(r, doc, base_dir, &config);
    read_root(r, doc, &config);
    if (!r.problems.empty()) throw ConfigError(source_name, r.problems);
    return config;
}

std::string read_config_file(const std::filesystem::path& file) {
    std::ifstream in(file);
    if (!in) throw ConfigError(file.string(), {"cannot open the file for reading"});
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

StationConfig load_station_config(const std::filesystem::path& file) {
    auto config = parse_station_config(read_config_file(file), file.string(), file.parent_path());
    config.source_file = file;
    return config;
}

namespace {

void write_configure(const SensorConfigure& c, YAML::Emitter* out) {
    if (!c.enabled) return;
    *out << YAML::Key << "configure" << YAML::Value;
    if (!c.udp_dest && !c.lidar_mode && !c.timestamp_mode) {
        *out << true;
        return;
    }
    *out << YAML::BeginMap;
    if (c.udp_dest) *out << YAML::Key << "udp_dest" << YAML::Value << *c.udp_dest;
    if (c.lidar_mode) *out << YAML::Key << "lidar_mode" << YAML::Value << *c.lidar_mode;
    if (c.timestamp_mode) *out << YAML::Key << "timestamp_mode" << YAML::Value << *c.timestamp_mode;
    *out << YAML::EndMap;
}

}  // namespace

std::string to_yaml(const StationConfig& config, const std::filesystem::path& base_dir) {
    YAML::Emitter out;
    out << YAML::BeginMap;
    out << YAML::Key << "station" << YAML::Value << config.station;
    out << YAML::Key << "root" << YAML::Value << config.root;
    out << YAML::Key << "sensors" << YAML::Value << YAML::BeginSeq;
    for (const auto& s : config.sensors) {
        out << YAML::BeginMap;
        out << YAML::Key << "name" << YAML::Value << s.name;
        if (!s.dds) out << YAML::Key << "udp_port" << YAML::Value << s.udp_port;
        std::filesystem::path meta = s.metadata;
        const auto relative = s.metadata.lexically_relative(base_dir);
        if (!base_dir.empty() && !relative.empty() && *relative.begin() != "..") meta = relative;
        if (s.dds) {
            out << YAML::Key << "source" << YAML::Value << YAML::BeginMap << YAML::Key << "dds"
                << YAML::Value << YAML::BeginMap << YAML::Key << "topic" << YAML::Value
                << s.dds->topic << YAML::Key << "domain_id" << YAML::Value << s.dds->domain_id
                << YAML::EndMap << YAML::EndMap;
        } else if (s.hostname) {
            out << YAML::Key << "hostname" << YAML::Value << *s.hostname;
            if (s.http_port != 80) out << YAML::Key << "http_port" << YAML::Value << s.http_port;
            write_configure(s.configure, &out);
        } else {
            out << YAML::Key << "metadata" << YAML::Value << meta.string();
        }
        if (s.source_address)
            out << YAML::Key << "source_address" << YAML::Value << *s.source_address;
        if (s.time_offset_ns != 0)
            out << YAML::Key << "time_offset_ns" << YAML::Value << s.time_offset_ns;
        if (!s.enabled) out << YAML::Key << "enabled" << YAML::Value << false;
        out << YAML::EndMap;
    }
    out << YAML::EndSeq << YAML::EndMap;
    return std::string(out.c_str()) + "\n";
}

}  // namespace lidarfuse::station

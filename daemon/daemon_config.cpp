#include "daemon/daemon_config.hpp"

#include <yaml-cpp/yaml.h>

#include "drivers/net/ipv4_address.hpp"
#include "drivers/station/fusion_config.hpp"
#include "drivers/station/yaml_reader.hpp"

namespace lidarfuse::daemon {

namespace {

using station::set_if;
using station::YamlReader;

void read_network(YamlReader& r, const YAML::Node& n, NetworkConfig* c) {
    if (!n || !r.optional_map(n, "network")) return;
    r.only_keys(n, "network", {"bind_address", "receive_buffer_bytes", "receive_coalesce_ms"});
    set_if(r.string(n["bind_address"], "network.bind_address", false), &c->bind_address);
    set_if(r.integer(n["receive_buffer_bytes"], "network.receive_buffer_bytes", 65536, 1LL << 30,
                     false),
           &c->receive_buffer_bytes);
    set_if(r.number(n["receive_coalesce_ms"], "network.receive_coalesce_ms", 0, 50, false),
           &c->receive_coalesce_ms);
}

void read_sync(YamlReader& r, const YAML::Node& n, SyncConfig* c) {
    if (!n || !r.optional_map(n, "sync")) return;
    r.only_keys(n, "sync",
                {"max_offset_ms", "deadline_ms", "reset_jump_ms", "max_clock_skew_ms",
                 "queue_depth", "when_behind"});
    set_if(r.number(n["max_offset_ms"], "sync.max_offset_ms", 0, 1000, false), &c->max_offset_ms);
    set_if(r.number(n["deadline_ms"], "sync.deadline_ms", 1, 10000, false), &c->deadline_ms);
    set_if(r.number(n["reset_jump_ms"], "sync.reset_jump_ms", 100, 3.6e6, false),
           &c->reset_jump_ms);
    set_if(r.number(n["max_clock_skew_ms"], "sync.max_clock_skew_ms", 0, 3.6e6, false),
           &c->max_clock_skew_ms);
    set_if(r.integer(n["queue_depth"], "sync.queue_depth", 1, 64, false), &c->queue_depth);
    if (auto when = r.choice(n["when_behind"], "sync.when_behind", {"predict", "drop"}))
        c->predict_when_behind = *when == 0;
}

// A ROS 2 namespace without the leading slash: segments of [A-Za-z0-9_], none starting with
// a digit, separated by single slashes.
bool valid_ros_namespace(const std::string& ns) {
    if (ns.empty()) return true;
    bool segment_start = true;
    for (std::size_t i = 0; i < ns.size(); ++i) {
        const char c = ns[i];
        if (c == '/') {
            if (segment_start || i + 1 == ns.size()) return false;
            segment_start = true;
            continue;
        }
        const bool digit = c >= '0' && c <= '9';
        const bool word = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' || digit;
        if (!word || (segment_start && digit)) return false;
        segment_start = false;
    }
    return true;
}

// output.dds.frame_prefix: "" (none), or the start of a tf frame id; what it makes of each
// frame is checked with the sensors (check_frame_names).
void read_frame_prefix(YamlReader& r, const YAML::Node& n, DdsConfig* c) {
    if (n && n.IsScalar() && n.Scalar().empty()) return;
    set_if(r.frame_id(n, "output.dds.frame_prefix"), &c->frame_prefix);
}

void read_dds(YamlReader& r, const YAML::Node& n, DdsConfig* c) {
    if (!n || !r.optional_map(n, "output.dds")) return;
    const std::string p = "output.dds.";
    r.only_keys(
        n, "output.dds",
        {"enabled", "domain_id", "namespace", "frame_id", "frame_prefix", "depth",
         "max_blocking_ms", "publish_points", "points_voxel_size_m", "diagnostics_period_ms"});
    set_if(r.boolean(n["enabled"], p + "enabled"), &c->enabled);
    // Cyclone maps domain d to UDP ports 7400 + 250 d + ..., so 232 is the largest id.
    set_if(r.integer(n["domain_id"], p + "domain_id", -1, 232, false), &c->domain_id);
    const YAML::Node ns_node = n["namespace"];
    if (ns_node && ns_node.IsScalar() && ns_node.Scalar().empty()) {
        c->topic_namespace.clear();  // "": rt/points, rt/poses
    } else if (auto ns = r.string(ns_node, p + "namespace", false)) {
        if (valid_ros_namespace(*ns)) {
            c->topic_namespace = *ns;
        } else {
            r.problems.push_back(
                p +
                "namespace: expected ROS name segments ([A-Za-z_][A-Za-z0-9_]*) joined by "
                "'/', without leading or trailing '/', got \"" +
                *ns + "\"");
        }
    }
    set_if(r.frame_id(n["frame_id"], p + "frame_id"), &c->frame_id);
    read_frame_prefix(r, n["frame_prefix"], c);
    set_if(r.integer(n["depth"], p + "depth", 1, 100, false), &c->depth);
    set_if(r.number(n["max_blocking_ms"], p + "max_blocking_ms", 0, 1000, false),
           &c->max_blocking_ms);
    set_if(r.boolean(n["publish_points"], p + "publish_points"), &c->publish_points);
    set_if(r.number(n["points_voxel_size_m"], p + "points_voxel_size_m", 0, 100, false),
           &c->points_voxel_size_m);
    set_if(r.number(n["diagnostics_period_ms"], p + "diagnostics_period_ms", 10, 60000, false),
           &c->diagnostics_period_ms);
}

void read_foxglove(YamlReader& r, const YAML::Node& n, FoxgloveConfig* c) {
    if (!n || !r.optional_map(n, "output.foxglove")) return;
    const std::string p = "output.foxglove.";
    r.only_keys(n, "output.foxglove",
                {"enabled", "bind_address", "port", "max_clients", "client_buffer_mb"});
    set_if(r.boolean(n["enabled"], p + "enabled"), &c->enabled);
    if (auto address = r.string(n["bind_address"], p + "bind_address", false)) {
        try {
            net::parse_ipv4(*address);
            c->bind_address = *address;
        } catch (const std::invalid_argument&) {
            r.problems.push_back(p +
                                 "bind_address: expected an IPv4 address such as 127.0.0.1 "
                                 "or 0.0.0.0, got \"" +
                                 *address + "\"");
        }
    }
    set_if(r.integer(n["port"], p + "port", 0, 65535, false), &c->port);
    set_if(r.integer(n["max_clients"], p + "max_clients", 1, 64, false), &c->max_clients);
    set_if(r.number(n["client_buffer_mb"], p + "client_buffer_mb", 0.1, 1024, false),
           &c->client_buffer_mb);
}

void read_record(YamlReader& r, const YAML::Node& n, const std::filesystem::path& base,
                 RecordConfig* c) {
    if (!n || !r.optional_map(n, "output.record")) return;
    const std::string p = "output.record.";
    r.only_keys(n, "output.record",
                {"enabled", "directory", "max_file_mb", "max_file_s", "min_free_mb",
                 "when_disk_low", "queue_mb"});
    set_if(r.boolean(n["enabled"], p + "enabled"), &c->enabled);
    if (auto d = r.string(n["directory"], p + "directory", false)) {
        const std::filesystem::path dir = *d;
        c->directory = dir.is_absolute() ? dir : (base / dir).lexically_normal();
    }
    set_if(r.number(n["max_file_mb"], p + "max_file_mb", 1, 1e6, false), &c->max_file_mb);
    set_if(r.number(n["max_file_s"], p + "max_file_s", 1, 86400, false), &c->max_file_s);
    set_if(r.number(n["min_free_mb"], p + "min_free_mb", 0, 1e9, false), &c->min_free_mb);
    set_if(r.number(n["queue_mb"], p + "queue_mb", 1, 4096, false), &c->queue_mb);
    if (auto policy =
            r.choice(n["when_disk_low"], p + "when_disk_low", {"remove_oldest", "stop"})) {
        c->when_disk_low = *policy == 1 ? LowDiskPolicy::kStop : LowDiskPolicy::kRemoveOldest;
    }
}

void read_output(YamlReader& r, const YAML::Node& n, const std::filesystem::path& base,
                 OutputConfig* c) {
    if (!n || !r.optional_map(n, "output")) return;
    r.only_keys(
        n, "output",
        {"directory", "poses_csv", "extrinsics_yaml", "extrinsics_interval_frames",
         "record_clouds_every", "record_clouds_format", "stamp", "dds", "foxglove", "record"});
    if (auto d = r.string(n["directory"], "output.directory", false)) {
        const std::filesystem::path dir = *d;
        c->directory = dir.is_absolute() ? dir : (base / dir).lexically_normal();
    }
    set_if(r.boolean(n["poses_csv"], "output.poses_csv"), &c->poses_csv);
    set_if(r.boolean(n["extrinsics_yaml"], "output.extrinsics_yaml"), &c->extrinsics_yaml);
    set_if(r.integer(n["extrinsics_interval_frames"], "output.extrinsics_interval_frames", 1,
                     1000000, false),
           &c->extrinsics_interval_frames);
    set_if(r.integer(n["record_clouds_every"], "output.record_clouds_every", 0, 1000000, false),
           &c->record_clouds_every);
    if (auto format =
            r.choice(n["record_clouds_format"], "output.record_clouds_format", {"ply", "pcd"})) {
        c->record_clouds_format =
            *format == 1 ? OutputConfig::CloudFormat::kPcd : OutputConfig::CloudFormat::kPly;
    }
    if (auto stamp = r.choice(n["stamp"], "output.stamp", {"sensor", "host"})) {
        c->stamp = *stamp == 0 ? StampSource::kSensor : StampSource::kHost;
    }
    read_dds(r, n["dds"], &c->dds);
    read_foxglove(r, n["foxglove"], &c->foxglove);
    if (c->foxglove.enabled && !c->dds.enabled) {
        r.problems.push_back(
            "output.foxglove.enabled: needs output.dds.enabled (the live view sends the CDR "
            "bytes of the DDS samples); enable DDS or disable output.foxglove");
    }
    read_record(r, n["record"], base, &c->record);
}

// Where sensors[i]'s tf frame comes from, for a message about a frame it collides with.
std::string frame_source(const station::StationConfig& station, std::size_t i) {
    const std::string at = "sensors[" + std::to_string(i) + "]";
    return station.sensors[i].dds && station.sensors[i].dds->frame_id
               ? at + ".source.dds.frame_id"
               : "the name of " + at + ", whose tf frame it is";
}

// tf2 keeps one parent per frame: the fused frame must not be a sensor's frame too, or that
// sensor would be its own parent (and dropped from tf), and no two sensors may share one.
// geo's world frame is the fused frame's parent on rt/tf_static: it must be neither the
// fused frame nor a sensor's frame.
void check_frame_names(const station::StationConfig& station, const DdsConfig& dds,
                       const station::WorldConfig& world, std::vector<std::string>* problems) {
    const bool geo = world.params.kind == core::WorldFrameKind::kGeo;
    const std::string fused = fused_frame_of(dds);
    if (!station::valid_frame_id(fused)) {
        problems->push_back("output.dds.frame_prefix: \"" + dds.frame_prefix +
                            "\" makes the fused frame \"" + fused +
                            "\", longer than tf's 128 characters");
    }
    const std::vector<std::string> frames = sensor_frames_of(station, dds);
    for (std::size_t i = 0; i < frames.size(); ++i) {
        if (frames[i] == fused) {
            problems->push_back("output.dds.frame_id: \"" + fused + "\" is also " +
                                frame_source(station, i) +
                                "; pick a name no sensor has (the default, lidarfuse/fused, "
                                "cannot collide)");
        }
        for (std::size_t j = 0; j < i; ++j) {
            if (frames[j] != frames[i]) continue;
            problems->push_back("sensors[" + std::to_string(i) + "]: its tf frame \"" + frames[i] +
                                "\" is also sensors[" + std::to_string(j) +
                                "]'s; each sensor needs a frame of its own "
                                "(source.dds.frame_id)");
        }
        if (geo && frames[i] == world.frame_id) {
            problems->push_back("world.frame_id: \"" + world.frame_id + "\" is also " +
                                frame_source(station, i) + "; pick a name no sensor has");
        }
    }
    if (geo && world.frame_id == fused) {
        problems->push_back(
            "world.frame_id: \"" + world.frame_id +
            "\" is also output.dds.frame_id; the world frame is the fused frame's parent, "
            "so they need different names");
    }
}

// A recording holds Ouster datagrams and their metadata; a DDS source's clouds are neither.
void check_record_sources(const station::StationConfig& station, const OutputConfig& output,
                          std::vector<std::string>* problems) {
    if (!output.record.enabled) return;
    for (std::size_t i = 0; i < station.sensors.size(); ++i) {
        if (!station.sensors[i].dds) continue;
        problems->push_back("output.record.enabled: records Ouster packets, and sensors[" +
                            std::to_string(i) + "] (\"" + station.sensors[i].name +
                            "\") takes its clouds from DDS; record them where they are made, "
                            "or disable output.record");
    }
}

void read_health(YamlReader& r, const YAML::Node& n, HealthConfig* c) {
    if (!n || !r.optional_map(n, "health")) return;
    r.only_keys(n, "health", {"stale_after_ms", "lost_after_ms", "min_completeness"});
    set_if(r.number(n["stale_after_ms"], "health.stale_after_ms", 10, 600000, false),
           &c->stale_after_ms);
    set_if(r.number(n["lost_after_ms"], "health.lost_after_ms", 10, 3600000, false),
           &c->lost_after_ms);
    set_if(r.number(n["min_completeness"], "health.min_completeness", 0, 1, false),
           &c->min_completeness);
    if (c->lost_after_ms < c->stale_after_ms) {
        r.problems.push_back("health.lost_after_ms: must not be below health.stale_after_ms");
    }
}

}  // namespace

DaemonConfig parse_daemon_config(const std::string& yaml_text, const std::string& source_name,
                                 const std::filesystem::path& base_dir) {
    DaemonConfig config;
    std::vector<std::string> problems;
    try {
        config.station = station::parse_station_config(yaml_text, source_name, base_dir);
    } catch (const station::ConfigError& error) {
        problems = error.problems();
    }
    YAML::Node doc;
    try {
        doc = YAML::Load(yaml_text);
    } catch (const YAML::Exception&) {
        throw station::ConfigError(source_name, problems);  // already reported as not YAML
    }
    if (!doc.IsMap()) throw station::ConfigError(source_name, problems);
    YamlReader r;
    read_network(r, doc["network"], &config.network);
    read_sync(r, doc["sync"], &config.sync);
    station::read_fusion_sections(r, doc, &config.fusion);
    read_output(r, doc["output"], base_dir, &config.output);
    read_health(r, doc["health"], &config.health);
    station::read_world_section(r, doc, config.station, &config.world);
    if (doc["logging"] && r.optional_map(doc["logging"], "logging")) {
        r.only_keys(doc["logging"], "logging", {"level"});
        if (auto level = r.string(doc["logging"]["level"], "logging.level", false)) {
            static const std::set<std::string> kLevels = {"trace", "debug", "info",
                                                          "warn",  "error", "off"};
            if (kLevels.count(*level)) {
                config.log_level = *level;
            } else {
                r.problems.push_back(
                    "logging.level: expected one of trace, debug, info, warn, error, off, got \"" +
                    *level + "\"");
            }
        }
    }
    problems.insert(problems.end(), r.problems.begin(), r.problems.end());
    check_frame_names(config.station, config.output.dds, config.world, &problems);
    check_record_sources(config.station, config.output, &problems);
    if (!problems.empty()) throw station::ConfigError(source_name, problems);
    config.fusion.root_sensor = config.station.root_index();
    return config;
}

DaemonConfig load_daemon_config(const std::filesystem::path& file) {
    auto config =
        parse_daemon_config(station::read_config_file(file), file.string(), file.parent_path());
    config.station.source_file = file;
    return config;
}

std::string fused_frame_of(const DdsConfig& dds) { return dds.frame_prefix + dds.frame_id; }

std::vector<std::string> sensor_frames_of(const station::StationConfig& station,
                                          const DdsConfig& dds) {
    std::vector<std::string> frames;
    for (const auto& sensor : station.sensors) {
        const bool given = sensor.dds && sensor.dds->frame_id;
        frames.push_back(given ? *sensor.dds->frame_id : dds.frame_prefix + sensor.name);
    }
    return frames;
}

std::filesystem::path record_directory(const OutputConfig& output) {
    return output.record.directory.empty() ? output.directory / "recordings"
                                           : output.record.directory;
}

}  // namespace lidarfuse::daemon

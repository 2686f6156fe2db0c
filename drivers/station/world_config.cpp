#include "drivers/station/world_config.hpp"

#include <cmath>

namespace lidarfuse::station {

namespace {

// A sequence of exactly `size` finite numbers, or nothing (and a problem).
std::optional<std::vector<double>> numbers(YamlReader& r, const YAML::Node& node,
                                           const std::string& path, std::size_t size,
                                           const char* what) {
    if (!node) {
        r.problems.push_back(path + ": missing (expected " + what + ")");
        return std::nullopt;
    }
    if (!node.IsSequence() || node.size() != size) {
        r.problems.push_back(path + ": expected " + what + ", got " + YamlReader::describe(node));
        return std::nullopt;
    }
    std::vector<double> out;
    for (std::size_t i = 0; i < size; ++i) {
        const auto v = r.number(node[i], path + "[" + std::to_string(i) + "]", -1e9, 1e9, true);
        if (!v) return std::nullopt;
        out.push_back(*v);
    }
    return out;
}

std::optional<Eigen::Isometry3d> read_transform(YamlReader& r, const YAML::Node& node,
                                                const std::string& path) {
    if (!r.optional_map(node, path)) return std::nullopt;
    r.only_keys(node, path, {"translation", "rotation_wxyz"});
    const auto t = numbers(r, node["translation"], path + ".translation", 3, "[x, y, z] in metres");
    const auto q = numbers(r, node["rotation_wxyz"], path + ".rotation_wxyz", 4,
                           "a unit quaternion [w, x, y, z]");
    if (!t || !q) return std::nullopt;
    const Eigen::Quaterniond rotation((*q)[0], (*q)[1], (*q)[2], (*q)[3]);
    if (std::abs(rotation.norm() - 1.0) > 1e-3) {
        r.problems.push_back(path + ".rotation_wxyz: expected a unit quaternion, its norm is " +
                             std::to_string(rotation.norm()));
        return std::nullopt;
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = rotation.normalized().toRotationMatrix();
    T.translation() = Eigen::Vector3d((*t)[0], (*t)[1], (*t)[2]);
    return T;
}

// world.frame; false (and a problem) when it names no world frame kind.
bool read_frame_kind(YamlReader& r, const YAML::Node& n, core::WorldFrameParams* p) {
    if (const auto frame = r.string(n["frame"], "world.frame", false)) {
        if (const auto kind = core::world_frame_kind_from(*frame)) {
            p->kind = *kind;
        } else {
            r.problems.push_back("world.frame: expected road, geo or sensor, got \"" + *frame +
                                 "\"");
            return false;
        }
    }
    return true;
}

// world.positions: sensor name -> [x, y, z] (m, world frame), at least 3 of them.
void read_positions(YamlReader& r, const YAML::Node& positions, const StationConfig& station,
                    core::WorldFrameParams* p) {
    if (!positions.IsMap()) {
        r.problems.push_back(
            "world.positions: expected a mapping of sensor name to [x, y, z], got " +
            YamlReader::describe(positions));
        return;
    }
    for (const auto& entry : positions) {
        const std::string name = entry.first.IsScalar() ? entry.first.Scalar() : std::string("?");
        const std::string path = "world.positions." + name;
        std::size_t index = station.sensors.size();
        for (std::size_t i = 0; i < station.sensors.size(); ++i) {
            if (station.sensors[i].name == name) index = i;
        }
        if (station.sensors.empty()) continue;  // the station section failed: reported there
        if (index == station.sensors.size()) {
            r.problems.push_back(path + ": \"" + name +
                                 "\" is not the name of a configured sensor");
            continue;
        }
        if (const auto xyz = numbers(r, entry.second, path, 3, "[x, y, z] in metres")) {
            p->anchors.push_back({index, Eigen::Vector3d((*xyz)[0], (*xyz)[1], (*xyz)[2])});
        }
    }
    if (positions.size() < 3) {
        r.problems.push_back("world.positions: expected at least 3 sensors, got " +
                             std::to_string(positions.size()));
    }
}

// What ties the geo frame to the station: either world.positions or world.T_world_root.
void read_geo_anchoring(YamlReader& r, const YAML::Node& positions, const YAML::Node& given,
                        const StationConfig& station, core::WorldFrameParams* p) {
    if (positions && given) {
        r.problems.push_back(
            "world.T_world_root: give either world.positions or world.T_world_root, not both");
        return;
    }
    if (!positions && !given) {
        r.problems.push_back(
            "world.positions: missing (world.frame: geo needs the known positions of at least 3 "
            "sensors, or world.T_world_root)");
        return;
    }
    if (given) {
        p->T_world_root = read_transform(r, given, "world.T_world_root");
        return;
    }
    read_positions(r, positions, station, p);
}

}  // namespace

void read_world_section(YamlReader& r, const YAML::Node& document, const StationConfig& station,
                        WorldConfig* world) {
    auto& p = world->params;
    p.root_sensor = station.root_index();
    const YAML::Node n = document["world"];
    if (!n || !r.optional_map(n, "world")) return;
    r.only_keys(n, "world", {"frame", "frame_id", "positions", "T_world_root", "average_frames"});
    if (!read_frame_kind(r, n, &p)) return;
    set_if(r.frame_id(n["frame_id"], "world.frame_id"), &world->frame_id);
    const bool geo = p.kind == core::WorldFrameKind::kGeo;
    const YAML::Node positions = n["positions"];
    const YAML::Node given = n["T_world_root"];
    const YAML::Node average = n["average_frames"];
    if (average && (!geo || !positions)) {
        r.problems.push_back("world.average_frames: only used with world.frame: geo and positions");
    } else if (const auto frames = r.integer(average, "world.average_frames", 1, 100000, false)) {
        p.geo_average_frames = static_cast<int>(*frames);
    }
    if (!geo) {
        // Given with another frame they would be ignored: refused, so that a forgotten
        // `frame: geo` does not silently publish an ungeoreferenced cloud.
        if (positions) r.problems.push_back("world.positions: only used with world.frame: geo");
        if (given) r.problems.push_back("world.T_world_root: only used with world.frame: geo");
        return;
    }
    read_geo_anchoring(r, positions, given, station, &p);
}

WorldConfig load_world_config(const std::filesystem::path& file, const StationConfig& station) {
    const YAML::Node document = load_config_document(read_config_file(file), file.string());
    WorldConfig world;
    YamlReader r;
    read_world_section(r, document, station, &world);
    if (!r.problems.empty()) throw ConfigError(file.string(), r.problems);
    return world;
}

}  // namespace lidarfuse::station

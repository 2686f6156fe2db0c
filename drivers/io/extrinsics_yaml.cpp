#include "drivers/io/extrinsics_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <stdexcept>

namespace lidarfuse::io {

namespace {

void emit_figures(YAML::Emitter& out, const char* key,
                  const std::map<std::string, double>& figures) {
    if (figures.empty()) return;
    out << YAML::Key << key << YAML::Value << YAML::BeginMap;
    for (const auto& [name, value] : figures) out << YAML::Key << name << YAML::Value << value;
    out << YAML::EndMap;
}

void emit_pose(YAML::Emitter& out, const char* key, const Eigen::Isometry3d& T) {
    Eigen::Quaterniond q(T.rotation());
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    const Eigen::Vector3d t = T.translation();
    out << YAML::Key << key << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "translation" << YAML::Value << YAML::Flow << YAML::BeginSeq << t.x()
        << t.y() << t.z() << YAML::EndSeq;
    out << YAML::Key << "rotation_wxyz" << YAML::Value << YAML::Flow << YAML::BeginSeq << q.w()
        << q.x() << q.y() << q.z() << YAML::EndSeq;
    out << YAML::EndMap;
}

void emit_sensor(YAML::Emitter& out, const ExtrinsicsEntry& s,
                 const std::optional<ExtrinsicsWorld>& world) {
    out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << s.name;
    out << YAML::Key << "registered" << YAML::Value << s.registered;
    if (s.registered) {
        emit_pose(out, "T_root_sensor", s.T_root_sensor);
        if (world) emit_pose(out, "T_fused_sensor", world->T_fused_root * s.T_root_sensor);
    } else if (!s.reason.empty()) {
        out << YAML::Key << "reason" << YAML::Value << s.reason;
    }
    emit_figures(out, "quality", s.quality);
    out << YAML::EndMap;
}

// The number at `node`; `where` names it in the error.
double read_number(const YAML::Node& node, const std::string& where) {
    try {
        return node.as<double>();
    } catch (const YAML::Exception&) {
        throw std::runtime_error(where + ": expected a number");
    }
}

// Reads a map of scalar figures at `node` (absent: empty); `where` names it in errors.
std::map<std::string, double> read_figures(const YAML::Node& node, const std::string& where) {
    std::map<std::string, double> figures;
    if (!node) return figures;
    if (!node.IsMap()) throw std::runtime_error(where + ": expected a map of numbers");
    for (const auto& kv : node) {
        const std::string key = kv.first.as<std::string>();
        figures[key] = read_number(kv.second, where + "." + key);
    }
    return figures;
}

// The pose `{translation, rotation_wxyz}` at `pose`; `path` names it in errors.
Eigen::Isometry3d read_pose(const YAML::Node& pose, const std::string& path) {
    if (!pose || !pose["translation"] || !pose["rotation_wxyz"]) {
        throw std::runtime_error(path + ": expected translation and rotation_wxyz");
    }
    const auto t = pose["translation"].as<std::vector<double>>();
    const auto q = pose["rotation_wxyz"].as<std::vector<double>>();
    if (t.size() != 3 || q.size() != 4) throw std::runtime_error(path + ": expected 3 + 4 numbers");
    for (const double v : t) {
        if (!std::isfinite(v)) throw std::runtime_error(path + ".translation: not finite");
    }
    const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
    if (!(std::abs(quat.norm() - 1.0) <= 1e-3))
        throw std::runtime_error(path + ".rotation_wxyz: not unit length");
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = quat.normalized().toRotationMatrix();
    T.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
    return T;
}

ExtrinsicsWorld read_world(const YAML::Node& node) {
    if (!node.IsMap()) throw std::runtime_error("world: expected a map");
    ExtrinsicsWorld w;
    if (!node["frame"]) throw std::runtime_error("world.frame: missing");
    w.frame = node["frame"].as<std::string>();
    if (node["fused_frame"]) w.fused_frame = node["fused_frame"].as<std::string>();
    w.T_fused_root = read_pose(node["T_fused_root"], "world.T_fused_root");
    if (node["world_frame"]) {
        w.world_frame = node["world_frame"].as<std::string>();
        w.T_world_fused = read_pose(node["T_world_fused"], "world.T_world_fused");
    }
    w.figures = read_figures(node["figures"], "world.figures");
    return w;
}

ExtrinsicsEntry read_sensor(const YAML::Node& node, const std::string& path) {
    ExtrinsicsEntry e;
    if (!node.IsMap()) throw std::runtime_error(path + ": expected a map");
    if (!node["name"]) throw std::runtime_error(path + ".name: missing");
    if (!node["registered"]) throw std::runtime_error(path + ".registered: missing");
    e.name = node["name"].as<std::string>();
    e.registered = node["registered"].as<bool>();
    if (e.registered) {
        e.T_root_sensor = read_pose(node["T_root_sensor"], path + ".T_root_sensor");
    } else if (node["reason"]) {
        e.reason = node["reason"].as<std::string>();
    }
    e.quality = read_figures(node["quality"], path + ".quality");
    return e;
}

ExtrinsicsPair read_pair(const YAML::Node& node, const std::string& path) {
    if (!node.IsMap()) throw std::runtime_error(path + ": expected a map");
    ExtrinsicsPair p;
    for (const auto& kv : node) {
        const std::string key = kv.first.as<std::string>();
        if (key == "source") {
            p.source = kv.second.as<std::string>();
        } else if (key == "target") {
            p.target = kv.second.as<std::string>();
        } else if (key == "status") {
            p.status = kv.second.as<std::string>();
        } else {
            p.figures[key] = read_number(kv.second, path + "." + key);
        }
    }
    if (p.source.empty() || p.target.empty())
        throw std::runtime_error(path + ": expected source and target");
    return p;
}

}  // namespace

std::string extrinsics_to_yaml(const ExtrinsicsDocument& document) {
    YAML::Emitter out;
    out.SetDoublePrecision(9);
    out << YAML::BeginMap;
    if (!document.station.empty()) out << YAML::Key << "station" << YAML::Value << document.station;
    out << YAML::Key << "root" << YAML::Value << document.root;
    out << YAML::Key << "sensors" << YAML::Value << YAML::BeginSeq;
    for (const auto& s : document.sensors) emit_sensor(out, s, document.world);
    out << YAML::EndSeq;
    if (document.world) {
        const auto& w = *document.world;
        out << YAML::Key << "world" << YAML::Value << YAML::BeginMap;
        out << YAML::Key << "frame" << YAML::Value << w.frame;
        if (!w.fused_frame.empty())
            out << YAML::Key << "fused_frame" << YAML::Value << w.fused_frame;
        emit_pose(out, "T_fused_root", w.T_fused_root);
        if (!w.world_frame.empty()) {
            out << YAML::Key << "world_frame" << YAML::Value << w.world_frame;
            emit_pose(out, "T_world_fused", w.T_world_fused);
        }
        emit_figures(out, "figures", w.figures);
        out << YAML::EndMap;
    }
    if (!document.pairs.empty()) {
        out << YAML::Key << "pairs" << YAML::Value << YAML::BeginSeq;
        for (const auto& p : document.pairs) {
            out << YAML::BeginMap << YAML::Key << "source" << YAML::Value << p.source;
            out << YAML::Key << "target" << YAML::Value << p.target;
            out << YAML::Key << "status" << YAML::Value << p.status;
            for (const auto& [name, value] : p.figures)
                out << YAML::Key << name << YAML::Value << value;
            out << YAML::EndMap;
        }
        out << YAML::EndSeq;
    }
    out << YAML::EndMap;
    std::string comment =
        "# T_root_sensor maps sensor coordinates into the root sensor's frame (metres)\n";
    if (document.world) {
        comment += "# T_fused_sensor into the published fused frame (world frame: " +
                   document.world->frame + ", see world:)\n";
    }
    return comment + std::string(out.c_str()) + "\n";
}

void write_extrinsics_yaml(const std::filesystem::path& file, const ExtrinsicsDocument& document) {
    const auto temporary = file.string() + ".tmp";
    {
        std::ofstream out(temporary, std::ios::trunc);
        if (!out) throw std::runtime_error(temporary + ": cannot open for writing");
        out << extrinsics_to_yaml(document);
        out.flush();
        if (!out) throw std::runtime_error(temporary + ": write failed");
    }
    std::error_code error;
    std::filesystem::rename(temporary, file, error);
    if (error) throw std::runtime_error(file.string() + ": cannot replace: " + error.message());
}

ExtrinsicsDocument read_extrinsics_document(const std::filesystem::path& file) {
    YAML::Node doc;
    try {
        doc = YAML::LoadFile(file.string());
    } catch (const YAML::Exception& error) {
        throw std::runtime_error(file.string() + ": " + error.what());
    }
    ExtrinsicsDocument out;
    try {
        if (!doc.IsMap() || !doc["sensors"] || !doc["sensors"].IsSequence()) {
            throw std::runtime_error("sensors: expected a list");
        }
        if (doc["station"]) out.station = doc["station"].as<std::string>();
        if (doc["root"]) out.root = doc["root"].as<std::string>();
        for (std::size_t i = 0; i < doc["sensors"].size(); ++i) {
            out.sensors.push_back(
                read_sensor(doc["sensors"][i], "sensors[" + std::to_string(i) + "]"));
        }
        if (doc["world"]) out.world = read_world(doc["world"]);
        if (doc["pairs"]) {
            if (!doc["pairs"].IsSequence()) throw std::runtime_error("pairs: expected a list");
            for (std::size_t i = 0; i < doc["pairs"].size(); ++i) {
                out.pairs.push_back(read_pair(doc["pairs"][i], "pairs[" + std::to_string(i) + "]"));
            }
        }
    } catch (const YAML::Exception& error) {
        throw std::runtime_error(file.string() + ": " + error.what());
    } catch (const std::runtime_error& error) {
        throw std::runtime_error(file.string() + ": " + error.what());
    }
    return out;
}

std::string extrinsics_to_yaml(const std::string& root,
                               const std::vector<ExtrinsicsEntry>& sensors) {
    return extrinsics_to_yaml(ExtrinsicsDocument{"", root, sensors, {}, std::nullopt});
}

void write_extrinsics_yaml(const std::filesystem::path& file, const std::string& root,
                           const std::vector<ExtrinsicsEntry>& sensors) {
    write_extrinsics_yaml(file, ExtrinsicsDocument{"", root, sensors, {}, std::nullopt});
}

std::vector<ExtrinsicsEntry> read_extrinsics_yaml(const std::filesystem::path& file,
                                                  std::string* root) {
    ExtrinsicsDocument document = read_extrinsics_document(file);
    if (root) *root = document.root;
    return std::move(document.sensors);
}

ExtrinsicsWorld extrinsics_world(const core::WorldFrame& frame, const std::string& fused_frame,
                                 const std::string& world_frame_id) {
    ExtrinsicsWorld w;
    w.frame = core::to_string(frame.kind);
    w.fused_frame = fused_frame;
    w.T_fused_root = frame.T_fused_root;
    if (frame.kind == core::WorldFrameKind::kGeo) {
        w.world_frame = world_frame_id;
        w.T_world_fused = frame.T_world_fused;
    }
    // road without road points (the planes alone, e.g. calibrate's): no residual measured,
    // none written rather than a 0 that reads as a perfect fit.
    const bool measured = frame.kind == core::WorldFrameKind::kGeo ||
                          (frame.kind == core::WorldFrameKind::kRoad && frame.num_road_points > 0);
    if (measured) {
        w.figures["residual_rms_m"] = frame.residual_rms_m;
        w.figures["residual_max_m"] = frame.residual_max_m;
    }
    if (frame.kind != core::WorldFrameKind::kSensor) {
        w.figures["sensors_used"] = static_cast<double>(frame.num_sensors);
    }
    if (frame.kind == core::WorldFrameKind::kRoad) {
        w.figures["root_height_m"] = frame.root_height_m;
        w.figures["road_points"] = static_cast<double>(frame.num_road_points);
    }
    if (frame.kind == core::WorldFrameKind::kGeo && frame.num_frames > 0) {
        w.figures["frames_averaged"] = static_cast<double>(frame.num_frames);
    }
    return w;
}

}  // namespace lidarfuse::io

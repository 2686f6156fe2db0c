#include "drivers/io/extrinsics_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <stdexcept>

namespace lidarfuse::io {

std::string extrinsics_to_yaml(const std::string& root, const std::vector<ExtrinsicsEntry>& sensors) {
    YAML::Emitter out;
    out.SetDoublePrecision(9);
    out << YAML::BeginMap << YAML::Key << "root" << YAML::Value << root;
    out << YAML::Key << "sensors" << YAML::Value << YAML::BeginSeq;
    for (const auto& s : sensors) {
        out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << s.name;
        out << YAML::Key << "registered" << YAML::Value << s.registered;
        if (s.registered) {
            Eigen::Quaterniond q(s.T_root_sensor.rotation());
            if (q.w() < 0) q.coeffs() = -q.coeffs();
            const Eigen::Vector3d t = s.T_root_sensor.translation();
            out << YAML::Key << "T_root_sensor" << YAML::Value << YAML::BeginMap;
            out << YAML::Key << "translation" << YAML::Value << YAML::Flow << YAML::BeginSeq << t.x()
                << t.y() << t.z() << YAML::EndSeq;
            out << YAML::Key << "rotation_wxyz" << YAML::Value << YAML::Flow << YAML::BeginSeq << q.w()
                << q.x() << q.y() << q.z() << YAML::EndSeq;
            out << YAML::EndMap;
        }
        if (!s.quality.empty()) {
            out << YAML::Key << "quality" << YAML::Value << YAML::BeginMap;
            for (const auto& [k, v] : s.quality) out << YAML::Key << k << YAML::Value << v;
            out << YAML::EndMap;
        }
        out << YAML::EndMap;
    }
    out << YAML::EndSeq << YAML::EndMap;
    return std::string(out.c_str()) + "\n";
}

void write_extrinsics_yaml(const std::filesystem::path& file, const std::string& root,
                           const std::vector<ExtrinsicsEntry>& sensors) {
    const auto temporary = file.string() + ".tmp";
    {
        std::ofstream out(temporary, std::ios::trunc);
        if (!out) throw std::runtime_error(temporary + ": cannot open for writing");
        out << extrinsics_to_yaml(root, sensors);
        out.flush();
        if (!out) throw std::runtime_error(temporary + ": write failed");
    }
    std::filesystem::rename(temporary, file);
}

std::vector<ExtrinsicsEntry> read_extrinsics_yaml(const std::filesystem::path& file, std::string* root) {
    YAML::Node doc;
    try {
        doc = YAML::LoadFile(file.string());
    } catch (const YAML::Exception& error) {
        throw std::runtime_error(file.string() + ": " + error.what());
    }
    const auto fail = [&](const std::string& what) { throw std::runtime_error(file.string() + ": " + what); };
    if (!doc.IsMap() || !doc["sensors"] || !doc["sensors"].IsSequence()) fail("sensors: expected a list");
    if (root) *root = doc["root"] ? doc["root"].as<std::string>() : "";
    std::vector<ExtrinsicsEntry> out;
    for (std::size_t i = 0; i < doc["sensors"].size(); ++i) {
        const auto node = doc["sensors"][i];
        const std::string path = "sensors[" + std::to_string(i) + "]";
        ExtrinsicsEntry e;
        try {
            e.name = node["name"].as<std::string>();
            e.registered = node["registered"].as<bool>();
            if (e.registered) {
                const auto t = node["T_root_sensor"]["translation"].as<std::vector<double>>();
                const auto q = node["T_root_sensor"]["rotation_wxyz"].as<std::vector<double>>();
                if (t.size() != 3 || q.size() != 4) fail(path + ".T_root_sensor: expected 3 + 4 numbers");
                Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
                if (std::abs(quat.norm() - 1.0) > 1e-3) fail(path + ".T_root_sensor.rotation_wxyz: not unit length");
                e.T_root_sensor.linear() = quat.normalized().toRotationMatrix();
                e.T_root_sensor.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
            }
            if (node["quality"]) {
                for (const auto& kv : node["quality"]) e.quality[kv.first.as<std::string>()] = kv.second.as<double>();
            }
        } catch (const YAML::Exception& error) {
            fail(path + ": " + error.what());
        }
        out.push_back(std::move(e));
    }
    return out;
}

}  // namespace lidarfuse::io

#include "drivers/io/pose_csv.hpp"

#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace lidarfuse::io {

namespace {

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> fields;
    std::string field;
    std::istringstream in(line);
    while (std::getline(in, field, ',')) fields.push_back(field);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    return fields;
}

[[noreturn]] void fail(const std::string& source, std::size_t line, const std::string& what) {
    throw std::runtime_error(source + ":" + std::to_string(line) + ": " + what);
}

std::int64_t to_int(const std::string& text, const std::string& source, std::size_t line,
                    const char* column) {
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(text.c_str(), &end, 10);
    if (text.empty() || *end != '\0' || errno == ERANGE) {
        fail(source, line, std::string(column) + ": expected an integer, got \"" + text + "\"");
    }
    return v;
}

double to_double(const std::string& text, const std::string& source, std::size_t line,
                 const char* column) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !std::isfinite(v)) {
        fail(source, line,
             std::string(column) + ": expected a finite number, got \"" + text + "\"");
    }
    return v;
}

}  // namespace

std::vector<PoseRecord> parse_pose_csv(std::istream& in, const std::string& source_name) {
    std::vector<PoseRecord> records;
    std::string line;
    std::size_t number = 0;
    if (!std::getline(in, line)) fail(source_name, 1, "empty file (expected a header line)");
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line != kPoseCsvHeader) {
        fail(source_name, number,
             std::string("expected the header \"") + kPoseCsvHeader + "\", got \"" + line + "\"");
    }
    static const char* const kColumns[] = {"frame", "sensor", "t_ns", "x",  "y",
                                           "z",     "qw",     "qx",   "qy", "qz"};
    while (std::getline(in, line)) {
        ++number;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty()) continue;
        const auto f = split(line);
        if (f.size() != 10) {
            fail(source_name, number, "expected 10 columns, got " + std::to_string(f.size()));
        }
        PoseRecord r;
        r.frame = to_int(f[0], source_name, number, kColumns[0]);
        if (f[1].empty()) fail(source_name, number, "sensor: empty name");
        r.sensor = f[1];
        r.t_ns = to_int(f[2], source_name, number, kColumns[2]);
        double v[7];
        for (int i = 0; i < 7; ++i)
            v[i] = to_double(f[3 + i], source_name, number, kColumns[3 + i]);
        Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
        if (std::abs(q.norm() - 1.0) > 1e-3) {
            fail(source_name, number,
                 "quaternion is not unit length (norm " + std::to_string(q.norm()) + ")");
        }
        q.normalize();
        r.pose = Eigen::Isometry3d::Identity();
        r.pose.linear() = q.toRotationMatrix();
        r.pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
        records.push_back(std::move(r));
    }
    return records;
}

std::vector<PoseRecord> read_pose_csv(const std::filesystem::path& file) {
    std::ifstream in(file);
    if (!in) throw std::runtime_error(file.string() + ": cannot open for reading");
    return parse_pose_csv(in, file.string());
}

void write_pose_csv_header(std::ostream& out) { out << kPoseCsvHeader << '\n'; }

void write_pose_csv_row(std::ostream& out, const PoseRecord& r) {
    Eigen::Quaterniond q(r.pose.rotation());
    if (q.w() < 0) q.coeffs() = -q.coeffs();  // one canonical sign
    const Eigen::Vector3d t = r.pose.translation();
    char buffer[320];
    std::snprintf(buffer, sizeof(buffer),
                  "%" PRId64 ",%s,%" PRId64 ",%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f\n", r.frame,
                  r.sensor.c_str(), r.t_ns, t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z());
    out << buffer;
}

void write_pose_csv(const std::filesystem::path& file, const std::vector<PoseRecord>& records) {
    const auto temporary = file.string() + ".tmp";
    {
        std::ofstream out(temporary, std::ios::trunc);
        if (!out) throw std::runtime_error(temporary + ": cannot open for writing");
        write_pose_csv_header(out);
        for (const auto& r : records) write_pose_csv_row(out, r);
        out.flush();
        if (!out) throw std::runtime_error(temporary + ": write failed");
    }
    std::filesystem::rename(temporary, file);
}

core::Trajectories to_trajectories(const std::vector<PoseRecord>& records,
                                   const Eigen::Vector3d& offset_m) {
    core::Trajectories out;
    for (const auto& r : records) {
        Eigen::Isometry3d pose = r.pose;
        pose.translation() += offset_m;
        out[r.sensor].push_back({r.frame, r.t_ns, pose});
    }
    return out;
}

}  // namespace lidarfuse::io

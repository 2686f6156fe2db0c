#pragma once
// Test helper for the simulator tests: decodes a `lidarfuse sim` output folder with the
// project's own ingest (station.yaml -> metadata -> PcapReader -> ScanAssembler -> xyz
// projection) and pairs every scan with ground_truth.csv. Header-only, tests only.

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "drivers/io/pose_csv.hpp"
#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/xyz_lut.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "drivers/station/station_config.hpp"

namespace lidarfuse::simtest {

struct DecodedScan {
    std::string sensor;
    std::uint32_t frame_id = 0;
    std::uint32_t init_id = 0;
    double completeness = 0;
    std::vector<Eigen::Vector3d> points_sensor;  // sensor frame, metres
    std::vector<Eigen::Vector3d> dirs_sensor;    // unit ray direction of each point
    std::vector<std::int64_t> t_ns;              // column timestamp of each point
    std::int64_t first_column_ns = 0;
    std::vector<std::uint32_t> range_mm;  // every pixel (H x W staggered)
};

struct DecodedCapture {
    station::StationConfig station;
    std::map<std::string, ouster::SensorInfo> infos;
    std::map<std::string, ouster::AssemblyCounters> counters;
    std::map<std::string, std::vector<DecodedScan>> scans;  // in emission order
    std::vector<io::PoseRecord> truth;
    pcap::PcapReaderStats pcap_stats;
};

inline DecodedCapture decode_sim_output(const std::filesystem::path& dir) {
    DecodedCapture out;
    out.station = station::load_station_config(dir / "station.yaml");
    out.truth = io::read_pose_csv(dir / "ground_truth.csv");
    std::map<std::uint16_t, std::string> by_port;
    std::map<std::string, std::unique_ptr<ouster::ScanAssembler>> assemblers;
    std::map<std::string, ouster::XyzLut> luts;
    for (const auto& s : out.station.sensors) {
        const auto info = ouster::load_metadata(s.metadata);
        out.infos[s.name] = info;
        by_port[s.udp_port] = s.name;
        luts[s.name] = ouster::make_xyz_lut(info);
        const std::string name = s.name;
        const ouster::XyzLut* lut = &luts[s.name];
        auto* scans = &out.scans[s.name];
        ouster::ScanAssemblerParams params;
        assemblers[name] = std::make_unique<ouster::ScanAssembler>(
            info, params, [name, lut, scans](const ouster::LidarScan& scan) {
                DecodedScan d;
                d.sensor = name;
                d.frame_id = scan.frame_id;
                d.init_id = scan.init_id;
                d.completeness = scan.completeness();
                d.range_mm = scan.range_mm;
                const std::size_t W = scan.columns();
                d.first_column_ns = static_cast<std::int64_t>(scan.timestamp_ns[0]);
                for (std::size_t i = 0; i < scan.range_mm.size(); ++i) {
                    const std::size_t col = i % W;
                    if (scan.range_mm[i] == 0 || !scan.received[col]) continue;
                    const int row = static_cast<int>(i / W);
                    d.points_sensor.push_back(
                        lut->point(row, static_cast<int>(col), scan.range_mm[i]));
                    d.dirs_sensor.push_back(
                        lut->direction.row(static_cast<Eigen::Index>(i)).transpose());
                    d.t_ns.push_back(static_cast<std::int64_t>(scan.timestamp_ns[col]));
                }
                scans->push_back(std::move(d));
            });
    }
    pcap::PcapReader reader(dir / "capture.pcap");
    pcap::UdpDatagram dg;
    while (reader.next(&dg)) {
        const auto it = by_port.find(dg.dst_port);
        if (it == by_port.end()) continue;
        assemblers[it->second]->add_packet(dg.data, dg.size);
    }
    for (auto& [name, a] : assemblers) {
        a->flush();
        out.counters[name] = a->counters();
    }
    out.pcap_stats = reader.stats();
    return out;
}

// Ground-truth pose of `sensor` at time t_ns, interpolated between the per-frame rows
// with a Catmull-Rom cubic (positions, and rotation vectors relative to the frame before),
// accurate to well below a millimetre for the pole sway; clamped at the ends.
inline Eigen::Isometry3d truth_at(const std::vector<io::PoseRecord>& truth,
                                  const std::string& sensor, std::int64_t t_ns) {
    std::vector<const io::PoseRecord*> rows;
    for (const auto& r : truth) {
        if (r.sensor == sensor) rows.push_back(&r);
    }
    std::size_t i = 0;
    while (i + 1 < rows.size() && rows[i + 1]->t_ns <= t_ns) ++i;
    if (i + 1 >= rows.size() || t_ns <= rows.front()->t_ns) return rows[i]->pose;
    const auto at = [&](std::ptrdiff_t k) {
        return rows[static_cast<std::size_t>(
            std::clamp<std::ptrdiff_t>(k, 0, static_cast<std::ptrdiff_t>(rows.size()) - 1))];
    };
    const auto ii = static_cast<std::ptrdiff_t>(i);
    const io::PoseRecord* p[4] = {at(ii - 1), at(ii), at(ii + 1), at(ii + 2)};
    const double a =
        static_cast<double>(t_ns - p[1]->t_ns) / static_cast<double>(p[2]->t_ns - p[1]->t_ns);
    const Eigen::Matrix3d R1 = p[1]->pose.linear();
    Eigen::Vector3d x[4], w[4];
    for (int k = 0; k < 4; ++k) {
        x[k] = p[k]->pose.translation();
        const Eigen::AngleAxisd aa(R1.transpose() * p[k]->pose.linear());
        w[k] = aa.angle() * aa.axis();
    }
    const auto cr = [a](const Eigen::Vector3d* v) {
        const double a2 = a * a, a3 = a2 * a;
        return 0.5 *
               ((2 * v[1]) + (-v[0] + v[2]) * a + (2 * v[0] - 5 * v[1] + 4 * v[2] - v[3]) * a2 +
                (-v[0] + 3 * v[1] - 3 * v[2] + v[3]) * a3);
    };
    const Eigen::Vector3d wi = cr(w);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = cr(x);
    T.linear() =
        R1 * (wi.norm() > 0 ? Eigen::AngleAxisd(wi.norm(), wi.normalized()).toRotationMatrix()
                            : Eigen::Matrix3d::Identity());
    return T;
}

// Pose row of the frame whose timestamp equals the scan's first column.
inline const io::PoseRecord* truth_row(const std::vector<io::PoseRecord>& truth,
                                       const std::string& sensor, std::int64_t t_ns) {
    for (const auto& r : truth) {
        if (r.sensor == sensor && r.t_ns == t_ns) return &r;
    }
    return nullptr;
}

}  // namespace lidarfuse::simtest

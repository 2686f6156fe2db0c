#include "bench/registration_diagnose_inputs.hpp"

#include <filesystem>
#include <map>
#include <stdexcept>

#include "core/common/point_cloud.hpp"
#include "drivers/capture/station_capture.hpp"
#include "drivers/io/cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"
#include "drivers/io/rig_reference.hpp"
#include "drivers/station/station_config.hpp"

namespace lidarfuse::bench {

namespace {

// The first complete scan of every sensor in `order`, and its time (ns). Its points rounded
// to float, as the FusionEngine's scan input (core::SensorScanInput) holds them.
void first_scans(const station::StationConfig& config, const std::string& pcap,
                 const std::vector<std::size_t>& order, std::vector<core::PointCloud>* clouds,
                 std::vector<std::int64_t>* t_ns) {
    capture::StationCapture capture(config, pcap);
    clouds->assign(config.sensors.size(), {});
    t_ns->assign(config.sensors.size(), -1);
    std::size_t have = 0;
    capture.run([&](const capture::CaptureScan& scan) {
        if (!scan.scan->complete() || (*t_ns)[scan.sensor] >= 0) return true;
        std::vector<Eigen::Vector3f> as_scanned;
        core::cast_points(scan.cloud->cloud.points, &as_scanned);
        core::cast_points(as_scanned, &(*clouds)[scan.sensor].points);
        (*t_ns)[scan.sensor] = scan.t_ns;
        return ++have < order.size();
    });
}

// The sensor's truth at `want_ns`, interpolated between the records around it.
Eigen::Isometry3d truth_at(const std::vector<io::PoseRecord>& truth, const std::string& sensor,
                           std::int64_t want_ns, const std::string& dir) {
    const io::PoseRecord* before = nullptr;
    const io::PoseRecord* after = nullptr;
    for (const auto& r : truth) {
        if (r.sensor != sensor) continue;
        if (r.t_ns <= want_ns && (before == nullptr || r.t_ns > before->t_ns)) before = &r;
        if (r.t_ns >= want_ns && (after == nullptr || r.t_ns < after->t_ns)) after = &r;
    }
    if (before == nullptr) before = after;
    if (after == nullptr) after = before;
    if (before == nullptr) throw std::runtime_error(dir + ": no truth for " + sensor);
    const double a = after->t_ns == before->t_ns ? 0.0
                                                 : static_cast<double>(want_ns - before->t_ns) /
                                                       (after->t_ns - before->t_ns);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = (1 - a) * before->pose.translation() + a * after->pose.translation();
    T.linear() = Eigen::Quaterniond(before->pose.linear())
                     .slerp(a, Eigen::Quaterniond(after->pose.linear()))
                     .toRotationMatrix();
    return T;
}

DiagnoseFrame load_simulated(const std::string& dir, double truth_shift_s) {
    const auto config = station::load_station_config(dir + "/station.yaml");
    const std::size_t root = config.root_index();
    std::vector<std::size_t> order{root};
    for (std::size_t s = 0; s < config.sensors.size(); ++s) {
        if (s != root && config.sensors[s].enabled) order.push_back(s);
    }
    std::vector<core::PointCloud> clouds;
    std::vector<std::int64_t> t_ns;
    first_scans(config, dir + "/capture.pcap", order, &clouds, &t_ns);
    const auto truth = io::read_pose_csv(dir + "/ground_truth.csv");
    DiagnoseFrame frame;
    for (std::size_t s : order) {
        frame.clouds.push_back(std::move(clouds[s]));
        frame.names.push_back(config.sensors[s].name);
        const std::int64_t want = t_ns[s] + static_cast<std::int64_t>(truth_shift_s * 1e9);
        frame.T_world_sensor.push_back(truth_at(truth, config.sensors[s].name, want, dir));
    }
    return frame;
}

// The rig's root and its references T_ROOT_NAME.txt, by NAME.
std::string rig_references(const std::string& dir,
                           std::map<std::string, Eigen::Isometry3d>* references) {
    std::string root;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        const auto sep = name.find('_', 2);
        if (name.rfind("T_", 0) != 0 || entry.path().extension() != ".txt" ||
            sep == std::string::npos)
            continue;
        const std::string a = name.substr(2, sep - 2);
        if (!root.empty() && a != root)
            throw std::runtime_error(dir + ": references from two roots, " + root + " and " + a);
        root = a;
        (*references)[entry.path().stem().string().substr(sep + 1)] =
            io::read_rig_reference(entry.path());
    }
    if (root.empty())
        throw std::runtime_error(dir + ": no station.yaml and no T_ROOT_NAME.txt references");
    return root;
}

core::PointCloud rig_cloud(const std::string& dir, const std::string& name) {
    for (const char* ext : {".pcd", ".ply"}) {
        if (std::filesystem::exists(dir + "/" + name + ext))
            return io::read_cloud_file(dir + "/" + name + ext).cloud;
    }
    throw std::runtime_error(dir + ": no " + name + ".pcd or " + name + ".ply");
}

DiagnoseFrame load_rig(const std::string& dir) {
    std::map<std::string, Eigen::Isometry3d> references;
    const std::string root = rig_references(dir, &references);
    DiagnoseFrame frame;
    frame.clouds.push_back(rig_cloud(dir, root));
    frame.names.push_back(root);
    frame.T_world_sensor.push_back(Eigen::Isometry3d::Identity());
    for (const auto& [name, T_root_name] : references) {
        frame.clouds.push_back(rig_cloud(dir, name));
        frame.names.push_back(name);
        frame.T_world_sensor.push_back(T_root_name);
    }
    return frame;
}

}  // namespace

DiagnoseFrame load_diagnose_frame(const std::string& dir, double truth_shift_s) {
    return std::filesystem::exists(dir + "/station.yaml") ? load_simulated(dir, truth_shift_s)
                                                          : load_rig(dir);
}

}  // namespace lidarfuse::bench

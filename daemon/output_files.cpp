#include "daemon/output_files.hpp"

#include <filesystem>
#include <utility>

#include "drivers/io/fused_cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"

namespace lidarfuse::daemon {

OutputFiles::OutputFiles(const OutputConfig& config, io::ExtrinsicsDocument extrinsics,
                         std::shared_ptr<spdlog::logger> log)
    : config_(config), extrinsics_(std::move(extrinsics)), log_(std::move(log)) {
    std::error_code ec;
    std::filesystem::create_directories(config_.directory, ec);
    if (ec) log_->error("cannot create {}: {}", config_.directory.string(), ec.message());
    open_poses();
}

void OutputFiles::open_poses() {
    if (!config_.poses_csv) return;
    poses_.close();
    const auto file = config_.directory / "poses.csv";
    const bool fresh = !std::filesystem::exists(file) || std::filesystem::file_size(file) == 0;
    poses_.open(file, std::ios::app);
    if (!poses_) log_->error("cannot open {} for appending", file.string());
    if (fresh) io::write_pose_csv_header(poses_);
}

void OutputFiles::reopen() {
    open_poses();
    write_extrinsics();
    log_->info("reopened poses.csv and rewrote extrinsics.yaml");
}

void OutputFiles::write_extrinsics() {
    if (!config_.extrinsics_yaml) return;
    try {
        io::write_extrinsics_yaml(config_.directory / "extrinsics.yaml", extrinsics_);
    } catch (const std::exception& error) {
        log_->error("{}", error.what());
    }
}

void OutputFiles::set_world(const core::WorldFrame& world, const std::string& fused_frame_id,
                            const std::string& world_frame_id) {
    if (!world.fixed || extrinsics_.world) return;
    extrinsics_.world = io::extrinsics_world(world, fused_frame_id, world_frame_id);
}

void OutputFiles::add_frame(const core::FrameOutput& frame, const Eigen::Isometry3d& T_root_fused) {
    add_poses(frame, T_root_fused);
    if (poses_) poses_.flush();
    ++frames_seen_;
    if (frames_seen_ == 1 || frames_seen_ % config_.extrinsics_interval_frames == 0)
        write_extrinsics();
    if (config_.record_clouds_every > 0 && frame.frame_index % config_.record_clouds_every == 0)
        write_cloud(frame);
}

void OutputFiles::add_poses(const core::FrameOutput& frame, const Eigen::Isometry3d& T_root_fused) {
    for (std::size_t s = 0; s < extrinsics_.sensors.size(); ++s) {
        const auto& h = frame.health[s];
        if (!h.pose_valid) continue;
        auto& e = extrinsics_.sensors[s];
        e.registered = true;
        e.T_root_sensor = T_root_fused * frame.T_root_sensor[s];
        e.quality["fitness_reference"] = h.fitness_reference;
        if (poses_ && h.included) {
            io::write_pose_csv_row(
                poses_, {frame.frame_index, e.name, frame.t_ns[s], frame.T_root_sensor[s]});
        }
    }
}

// fused_<frame index>.ply or .pcd (output.record_clouds_format).
void OutputFiles::write_cloud(const core::FrameOutput& frame) {
    try {
        const bool pcd = config_.record_clouds_format == OutputConfig::CloudFormat::kPcd;
        const auto file = config_.directory /
                          ("fused_" + std::to_string(frame.frame_index) + (pcd ? ".pcd" : ".ply"));
        if (pcd) {
            io::write_fused_cloud_pcd(file, frame.cloud);
        } else {
            io::write_fused_cloud_ply(file, frame.cloud);
        }
    } catch (const std::exception& error) {
        log_->error("{}", error.what());
    }
}

}  // namespace lidarfuse::daemon

#pragma once
// The output thread's files in output.directory: poses.csv (appended per frame), extrinsics.yaml
// (rewritten after the first frame, every extrinsics_interval_frames frames, on request and at
// the end) and every record_clouds_every-th fused cloud. A file that cannot be written is
// logged, never thrown. Output thread only.

#include <spdlog/logger.h>

#include <Eigen/Geometry>
#include <cstdint>
#include <fstream>
#include <memory>
#include <string>

#include "core/pipeline/fusion_types.hpp"
#include "core/pipeline/world_frame.hpp"
#include "daemon/daemon_config.hpp"
#include "drivers/io/extrinsics_yaml.hpp"

namespace lidarfuse::daemon {

class OutputFiles {
public:
    // Creates the directory and opens poses.csv. `extrinsics`: the station, the root and
    // every sensor's name, in config order.
    OutputFiles(const OutputConfig& config, io::ExtrinsicsDocument extrinsics,
                std::shared_ptr<spdlog::logger> log);

    // SIGHUP (after logrotate): re-open poses.csv and rewrite extrinsics.yaml.
    void reopen();
    void write_extrinsics();
    // The world frame's block of extrinsics.yaml, once it is fixed.
    void set_world(const core::WorldFrame& world, const std::string& fused_frame_id,
                   const std::string& world_frame_id);
    // A fused frame (poses in the fused frame): every registered sensor's T_root_sensor
    // (T_root_fused * T_fused_sensor) into extrinsics.yaml, the included ones' poses into
    // poses.csv; then extrinsics.yaml and the cloud when due.
    void add_frame(const core::FrameOutput& frame, const Eigen::Isometry3d& T_root_fused);

private:
    // Appends (the header first when the file is new or empty); nothing when poses_csv is off.
    void open_poses();
    void add_poses(const core::FrameOutput& frame, const Eigen::Isometry3d& T_root_fused);
    void write_cloud(const core::FrameOutput& frame);

    const OutputConfig& config_;
    io::ExtrinsicsDocument extrinsics_;
    std::shared_ptr<spdlog::logger> log_;
    std::ofstream poses_;
    std::int64_t frames_seen_ = 0;
};

}  // namespace lidarfuse::daemon

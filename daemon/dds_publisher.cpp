#include "daemon/dds_publisher.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace lidarfuse::daemon {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string dds_error(dds_return_t rc) { return dds_strretcode(rc); }

// Reliable, keep-last `depth`, XCDR1, volatile or transient-local.
dds_qos_t* writer_qos(int depth, double max_blocking_ms, bool transient_local) {
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE,
                         static_cast<dds_duration_t>(max_blocking_ms * 1e6));
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, depth);
    dds_qset_durability(qos,
                        transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
    const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
    dds_qset_data_representation(qos, 1, &xcdr1);
    return qos;
}

}  // namespace

int resolve_domain_id(int configured, const char* ros_domain_id) {
    if (configured >= 0) return configured;
    if (!ros_domain_id || !*ros_domain_id) return 0;
    char* end = nullptr;
    const long id = std::strtol(ros_domain_id, &end, 10);
    if (*end != '\0' || id < 0 || id > 232) {
        throw std::runtime_error(
            std::string("ROS_DOMAIN_ID: expected an integer in 0..232, got \"") + ros_domain_id +
            "\" (or set output.dds.domain_id)");
    }
    return static_cast<int>(id);
}

std::string ros_topic_name(const std::string& topic_namespace, const std::string& leaf) {
    return topic_namespace.empty() ? "rt/" + leaf : "rt/" + topic_namespace + "/" + leaf;
}

DdsPublisher::DdsPublisher(const DdsConfig& config, StationFrames frames)
    : config_(config),
      frames_(std::move(frames)),
      domain_id_(resolve_domain_id(config.domain_id, std::getenv("ROS_DOMAIN_ID"))),
      frame_builder_(frames_),
      static_builder_(frames_),
      diagnostics_builder_(frames_) {
    participant_ =
        dds_create_participant(static_cast<dds_domainid_t>(domain_id_), nullptr, nullptr);
    if (participant_ < 0) {
        throw std::runtime_error("DDS: cannot create a participant on domain " +
                                 std::to_string(domain_id_) + ": " + dds_error(participant_) +
                                 " (check CYCLONEDDS_URI)");
    }
    const auto make_writer = [&](const std::string& name, const dds_topic_descriptor_t* type,
                                 int depth, bool transient_local) {
        const dds_entity_t topic =
            dds_create_topic(participant_, type, name.c_str(), nullptr, nullptr);
        if (topic < 0) {
            dds_delete(participant_);
            throw std::runtime_error("DDS: cannot create topic " + name + ": " + dds_error(topic));
        }
        dds_qos_t* qos = writer_qos(depth, config_.max_blocking_ms, transient_local);
        const dds_entity_t writer = dds_create_writer(participant_, topic, qos, nullptr);
        dds_delete_qos(qos);
        if (writer < 0) {
            dds_delete(participant_);
            throw std::runtime_error("DDS: cannot create a writer on " + name + ": " +
                                     dds_error(writer));
        }
        return writer;
    };
    const int depth = config_.depth;
    if (config_.publish_points) {
        points_writer_ = make_writer(ros_topic_name(config_.topic_namespace, "points"),
                                     &sensor_msgs_msg_dds__PointCloud2__desc, depth, false);
    }
    poses_writer_ = make_writer(ros_topic_name(config_.topic_namespace, "poses"),
                                &lidarfuse_msgs_msg_dds__FramePoses__desc, depth, false);
    tf_writer_ = make_writer("rt/tf", &tf2_msgs_msg_dds__TFMessage__desc, depth, false);
    // As tf2's static broadcaster: one message with every static transform, depth 1, so a
    // late joiner gets exactly the latest set.
    tf_static_writer_ = make_writer("rt/tf_static", &tf2_msgs_msg_dds__TFMessage__desc, 1, true);
    diagnostics_writer_ = make_writer(
        "rt/diagnostics", &diagnostic_msgs_msg_dds__DiagnosticArray__desc, depth, false);
    static_T_.assign(frames_.sensor_names.size(), Eigen::Isometry3d::Identity());
    static_valid_.assign(frames_.sensor_names.size(), false);
}

DdsPublisher::~DdsPublisher() {
    if (participant_ > 0) dds_delete(participant_);
}

bool DdsPublisher::write(dds_entity_t writer, const void* sample, Counter* topic_counter) {
    const dds_return_t rc = dds_write(writer, sample);
    if (rc == DDS_RETCODE_OK) {
        written_.value.fetch_add(1, std::memory_order_relaxed);
        topic_counter->value.fetch_add(1, std::memory_order_relaxed);
        return true;
    }
    failures_.value.fetch_add(1, std::memory_order_relaxed);
    if (rc == DDS_RETCODE_TIMEOUT) timeouts_.value.fetch_add(1, std::memory_order_relaxed);
    return false;
}

// Static transforms go out with the first registered poses, and again whenever a sensor is
// registered that was not in the last set or one has moved beyond the thresholds.
bool DdsPublisher::static_transforms_changed(const core::FrameOutput& frame) const {
    for (std::size_t s = 0; s < frame.health.size() && s < static_valid_.size(); ++s) {
        if (!frame.health[s].pose_valid) continue;
        if (!static_valid_[s]) return true;
        const Eigen::Isometry3d delta = static_T_[s].inverse() * frame.T_root_sensor[s];
        const double angle_deg = Eigen::AngleAxisd(delta.rotation()).angle() * 180.0 / kPi;
        if (delta.translation().norm() > config_.static_update_m ||
            angle_deg > config_.static_update_deg) {
            return true;
        }
    }
    return false;
}

void DdsPublisher::publish_frame(const core::FrameOutput& frame) {
    if (points_writer_ > 0) write(points_writer_, &frame_builder_.cloud(frame), &clouds_);
    write(tf_writer_, &frame_builder_.tf(frame), &tf_);
    write(poses_writer_, &frame_builder_.poses(frame), &poses_);
    if (static_transforms_changed(frame)) static_pending_ = true;
    if (static_pending_) {
        std::vector<std::int64_t> t_ns(static_T_.size(), 0);
        for (std::size_t s = 0; s < static_T_.size() && s < frame.health.size(); ++s) {
            if (!frame.health[s].pose_valid) continue;
            static_T_[s] = frame.T_root_sensor[s];
            static_valid_[s] = true;
        }
        for (std::size_t s = 0; s < t_ns.size() && s < frame.t_ns.size(); ++s)
            t_ns[s] = frame.t_ns[s];
        // A failed write is retried with the next frame's poses.
        static_pending_ = !write(tf_static_writer_,
                                 &static_builder_.tf(static_T_, t_ns, static_valid_), &tf_static_);
    }
}

void DdsPublisher::publish_diagnostics(const PipelineStats& stats, std::int64_t stamp_ns) {
    write(diagnostics_writer_, &diagnostics_builder_.build(stats, stamp_ns), &diagnostics_);
}

DdsCounters DdsPublisher::counters() const {
    DdsCounters c;
    c.written = written_.value.load();
    c.failures = failures_.value.load();
    c.timeouts = timeouts_.value.load();
    c.clouds = clouds_.value.load();
    c.tf = tf_.value.load();
    c.tf_static = tf_static_.value.load();
    c.poses = poses_.value.load();
    c.diagnostics = diagnostics_.value.load();
    return c;
}

}  // namespace lidarfuse::daemon

#include "daemon/dds_publisher.hpp"

#include <cstdlib>
#include <stdexcept>

#include "daemon/foxglove_server.hpp"
#include "daemon/ros_type_hash.hpp"
#include "daemon/sensor_ingest.hpp"

namespace lidarfuse::daemon {

namespace {

std::string dds_error(dds_return_t rc) { return dds_strretcode(rc); }

// Reliable, keep-last `depth`, XCDR1, volatile, and the type hash in USER_DATA as
// rmw_cyclonedds_cpp puts it there for a topic's writer.
// rt/tf_static is transient-local with a depth of 1, as tf2_ros's static broadcaster: a
// listener that starts later still gets the last message.
dds_qos_t* writer_qos(int depth, double max_blocking_ms, const std::string& user_data,
                      bool transient_local = false) {
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE,
                         static_cast<dds_duration_t>(max_blocking_ms * 1e6));
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, depth);
    dds_qset_durability(qos,
                        transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
    const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
    dds_qset_data_representation(qos, 1, &xcdr1);
    dds_qset_userdata(qos, user_data.data(), user_data.size());
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

DdsPublisher::DdsPublisher(const DdsConfig& config, StationFrames frames,
                           std::string static_parent_frame)
    : config_(config),
      frames_(std::move(frames)),
      static_parent_frame_(std::move(static_parent_frame)),
      domain_id_(resolve_domain_id(config.domain_id, std::getenv("ROS_DOMAIN_ID"))),
      frame_builder_(frames_),
      voxel_builder_(frames_),
      diagnostics_builder_(frames_) {
    participant_ =
        dds_create_participant(static_cast<dds_domainid_t>(domain_id_), nullptr, nullptr);
    if (participant_ < 0) {
        throw std::runtime_error("DDS: cannot create a participant on domain " +
                                 std::to_string(domain_id_) + ": " + dds_error(participant_) +
                                 " (check CYCLONEDDS_URI)");
    }
    const auto make_writer = [&](const std::string& name, const dds_topic_descriptor_t* type,
                                 int depth, bool transient_local = false) {
        const dds_entity_t topic =
            dds_create_topic(participant_, type, name.c_str(), nullptr, nullptr);
        if (topic < 0) {
            dds_delete(participant_);
            throw std::runtime_error("DDS: cannot create topic " + name + ": " + dds_error(topic));
        }
        dds_qos_t* qos = writer_qos(depth, config_.max_blocking_ms,
                                    ros_type_hash_user_data(type->m_typename), transient_local);
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
                                     &sensor_msgs_msg_dds__PointCloud2__desc, depth);
    }
    if (config_.points_voxel_size_m > 0) {
        voxel_writer_ = make_writer(ros_topic_name(config_.topic_namespace, "points_voxel"),
                                    &sensor_msgs_msg_dds__PointCloud2__desc, depth);
    }
    poses_writer_ = make_writer(ros_topic_name(config_.topic_namespace, "poses"),
                                &lidarfuse_msgs_msg_dds__FramePoses__desc, depth);
    tf_writer_ = make_writer("rt/tf", &tf2_msgs_msg_dds__TFMessage__desc, depth);
    diagnostics_writer_ =
        make_writer("rt/diagnostics", &diagnostic_msgs_msg_dds__DiagnosticArray__desc, depth);
    if (!static_parent_frame_.empty()) {
        tf_static_writer_ =
            make_writer("rt/tf_static", &tf2_msgs_msg_dds__TFMessage__desc, 1, true);
    }
}

DdsPublisher::~DdsPublisher() {
    if (participant_ > 0) dds_delete(participant_);
}

bool DdsPublisher::write(dds_entity_t writer, const dds_topic_descriptor_t& type,
                         const void* sample, Counter* topic_counter, FoxgloveChannel channel) {
    // The live view first: a DDS write that timed out must not hide the sample there too.
    if (foxglove_ && foxglove_->wants(channel)) {
        foxglove_->publish(channel, realtime_ns(), cdr_.write(type, sample));
    }
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

void DdsPublisher::publish_frame(const core::FrameOutput& frame, const FrameStamps& stamps) {
    if (stamps.frame_ns <= 0) {  // no sensor stamped: a message would carry stamp 0
        unstamped_.value.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    if (points_writer_ > 0) {
        write(points_writer_, sensor_msgs_msg_dds__PointCloud2__desc,
              &frame_builder_.cloud(frame, stamps), &clouds_, FoxgloveChannel::kPoints);
    }
    if (voxel_writer_ > 0 && voxel_cloud_wanted()) {
        voxels_.downsample(frame.cloud, config_.points_voxel_size_m, &voxel_cloud_);
        write(voxel_writer_, sensor_msgs_msg_dds__PointCloud2__desc,
              &voxel_builder_.cloud(voxel_cloud_, stamps), &voxel_clouds_,
              FoxgloveChannel::kPointsVoxel);
    }
    const auto& tf = frame_builder_.tf(frame, stamps);
    if (tf.transforms._length > 0) {
        write(tf_writer_, tf2_msgs_msg_dds__TFMessage__desc, &tf, &tf_, FoxgloveChannel::kTf);
    }
    write(poses_writer_, lidarfuse_msgs_msg_dds__FramePoses__desc,
          &frame_builder_.poses(frame, stamps), &poses_, FoxgloveChannel::kPoses);
}

// A DDS reader matched, or a live-view client subscribed: thinning costs a pass over the
// fused cloud, which nobody may want.
bool DdsPublisher::voxel_cloud_wanted() const {
    if (foxglove_ && foxglove_->wants(FoxgloveChannel::kPointsVoxel)) return true;
    dds_publication_matched_status_t matched{};
    return dds_get_publication_matched_status(voxel_writer_, &matched) == DDS_RETCODE_OK &&
           matched.current_count > 0;
}

void DdsPublisher::publish_static(const Eigen::Isometry3d& T_parent_fused, std::int64_t stamp_ns) {
    if (tf_static_writer_ <= 0 || stamp_ns <= 0) return;  // never a stamp 0
    if (static_sent_ && T_parent_fused.isApprox(static_sent_pose_, 1e-12)) return;  // unchanged
    geometry_msgs_msg_dds__TransformStamped_ t{};
    t.header.stamp = to_ros_time(stamp_ns);
    t.header.frame_id = const_cast<char*>(static_parent_frame_.c_str());
    t.child_frame_id = const_cast<char*>(frames_.fused_frame.c_str());
    t.transform = to_ros_transform(T_parent_fused);
    tf2_msgs_msg_dds__TFMessage_ message{};
    message.transforms._buffer = &t;
    message.transforms._length = message.transforms._maximum = 1;
    message.transforms._release = false;
    if (write(tf_static_writer_, tf2_msgs_msg_dds__TFMessage__desc, &message, &tf_static_,
              FoxgloveChannel::kTfStatic)) {
        static_sent_ = true;
        static_sent_pose_ = T_parent_fused;
    }
}

void DdsPublisher::publish_diagnostics(const PipelineStats& stats, std::int64_t stamp_ns) {
    write(diagnostics_writer_, diagnostic_msgs_msg_dds__DiagnosticArray__desc,
          &diagnostics_builder_.build(stats, stamp_ns), &diagnostics_,
          FoxgloveChannel::kDiagnostics);
}

DdsCounters DdsPublisher::counters() const {
    DdsCounters c;
    c.written = written_.value.load();
    c.failures = failures_.value.load();
    c.timeouts = timeouts_.value.load();
    c.clouds = clouds_.value.load();
    c.voxel_clouds = voxel_clouds_.value.load();
    c.tf = tf_.value.load();
    c.tf_static = tf_static_.value.load();
    c.poses = poses_.value.load();
    c.diagnostics = diagnostics_.value.load();
    c.unstamped_frames = unstamped_.value.load();
    return c;
}

}  // namespace lidarfuse::daemon

#include "daemon/dds_messages.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "daemon/status_line.hpp"

namespace lidarfuse::daemon {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "PointCloud2 data is written in host order");

namespace {

// The C structs hold `char*`; the builders only ever hand them strings they own and Cyclone
// only reads them.
char* c_str(const std::string& s) { return const_cast<char*>(s.c_str()); }

template <typename T, typename Seq>
void point_sequence(Seq* seq, std::vector<T>& items) {
    seq->_buffer = items.empty() ? nullptr : items.data();
    seq->_length = static_cast<std::uint32_t>(items.size());
    seq->_maximum = seq->_length;
    seq->_release = false;  // the builder owns the buffer, Cyclone must never free it
}

}  // namespace

builtin_interfaces_msg_dds__Time_ to_ros_time(std::int64_t t_ns) {
    std::int64_t sec = t_ns / 1'000'000'000;
    std::int64_t nsec = t_ns % 1'000'000'000;
    if (nsec < 0) {
        nsec += 1'000'000'000;
        --sec;
    }
    return {static_cast<std::int32_t>(sec), static_cast<std::uint32_t>(nsec)};
}

std::int64_t from_ros_time(const builtin_interfaces_msg_dds__Time_& t) {
    return static_cast<std::int64_t>(t.sec) * 1'000'000'000 + static_cast<std::int64_t>(t.nanosec);
}

geometry_msgs_msg_dds__Transform_ to_ros_transform(const Eigen::Isometry3d& T) {
    const Eigen::Quaterniond q(T.rotation());
    const Eigen::Vector3d p = T.translation();
    return {{p.x(), p.y(), p.z()}, {q.x(), q.y(), q.z(), q.w()}};
}

Eigen::Isometry3d from_ros_transform(const geometry_msgs_msg_dds__Transform_& t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(t.translation.x, t.translation.y, t.translation.z);
    T.linear() = Eigen::Quaterniond(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z)
                     .normalized()
                     .toRotationMatrix();
    return T;
}

FrameMessageBuilder::FrameMessageBuilder(StationFrames frames) : frames_(std::move(frames)) {
    if (frames_.sensor_frames.empty()) frames_.sensor_frames = frames_.sensor_names;
    if (frames_.sensor_frames.size() != frames_.sensor_names.size())
        throw std::invalid_argument("a tf frame for each sensor, or none");
    for (const auto& frame : frames_.sensor_frames) {
        if (frame == frames_.fused_frame)
            throw std::invalid_argument("fused frame \"" + frame + "\" is also a sensor's frame");
    }
    static const char* const kNames[6] = {"x", "y", "z", "intensity", "sensor_id", "dynamic"};
    const std::uint32_t offsets[6] = {kOffsetX,         kOffsetY,        kOffsetZ,
                                      kOffsetIntensity, kOffsetSensorId, kOffsetDynamic};
    const std::uint8_t types[6] = {sensor_msgs_msg_dds__PointField_Constants_FLOAT32,
                                   sensor_msgs_msg_dds__PointField_Constants_FLOAT32,
                                   sensor_msgs_msg_dds__PointField_Constants_FLOAT32,
                                   sensor_msgs_msg_dds__PointField_Constants_FLOAT32,
                                   sensor_msgs_msg_dds__PointField_Constants_UINT8,
                                   sensor_msgs_msg_dds__PointField_Constants_UINT8};
    for (int i = 0; i < 6; ++i)
        fields_[i] = {const_cast<char*>(kNames[i]), offsets[i], types[i], 1};
    cloud_.fields._buffer = fields_;
    cloud_.fields._length = cloud_.fields._maximum = 6;
    cloud_.fields._release = false;
    cloud_.header.frame_id = c_str(frames_.fused_frame);
    cloud_.height = 1;
    cloud_.is_bigendian = false;
    cloud_.point_step = kPointStep;
    cloud_.is_dense = true;
    tf_.transforms._release = false;
    poses_.header.frame_id = c_str(frames_.fused_frame);
    poses_.root_sensor = c_str(frames_.sensor_names.at(frames_.root));
    transforms_.reserve(frames_.sensor_names.size());
    sensor_poses_.resize(frames_.sensor_names.size());
}

const sensor_msgs_msg_dds__PointCloud2_& FrameMessageBuilder::cloud(const core::FusedCloud& c,
                                                                    const FrameStamps& stamps) {
    const std::size_t n = c.points.size();
    cloud_data_.resize(n * kPointStep);  // grows to the largest cloud, then stays
    std::uint8_t* out = cloud_data_.data();
    for (std::size_t i = 0; i < n; ++i, out += kPointStep) {
        const float xyz[3] = {c.points[i].x(), c.points[i].y(), c.points[i].z()};
        const float intensity = i < c.intensity.size() ? c.intensity[i] : 0.0f;
        std::memcpy(out + kOffsetX, xyz, sizeof(xyz));
        std::memcpy(out + kOffsetIntensity, &intensity, sizeof(float));
        out[kOffsetSensorId] = i < c.sensor.size() ? c.sensor[i] : 0;
        out[kOffsetDynamic] = i < c.dynamic.size() ? c.dynamic[i] : 0;
        out[18] = out[19] = 0;
    }
    cloud_.header.stamp = to_ros_time(stamps.frame_ns);
    cloud_.width = static_cast<std::uint32_t>(n);
    cloud_.row_step = static_cast<std::uint32_t>(n * kPointStep);
    point_sequence(&cloud_.data, cloud_data_);
    return cloud_;
}

const tf2_msgs_msg_dds__TFMessage_& FrameMessageBuilder::tf(const core::FrameOutput& frame,
                                                            const FrameStamps& stamps) {
    transforms_.clear();
    for (std::size_t s = 0; s < frames_.sensor_names.size() && s < frame.health.size(); ++s) {
        if (!frame.health[s].pose_valid || s >= stamps.sensor_ns.size() ||
            stamps.sensor_ns[s] <= 0) {
            continue;
        }
        geometry_msgs_msg_dds__TransformStamped_ t{};
        t.header.stamp = to_ros_time(stamps.sensor_ns[s]);
        t.header.frame_id = c_str(frames_.fused_frame);
        t.child_frame_id = c_str(frames_.sensor_frames[s]);
        t.transform = to_ros_transform(frame.T_root_sensor[s]);
        transforms_.push_back(t);
    }
    point_sequence(&tf_.transforms, transforms_);
    return tf_;
}

const lidarfuse_msgs_msg_dds__FramePoses_& FrameMessageBuilder::poses(
    const core::FrameOutput& frame, const FrameStamps& stamps) {
    poses_.header.stamp = to_ros_time(stamps.frame_ns);
    poses_.frame_index = frame.frame_index;
    const std::size_t n = std::min(sensor_poses_.size(), frame.health.size());
    for (std::size_t s = 0; s < n; ++s) {
        auto& p = sensor_poses_[s];
        const auto& h = frame.health[s];
        p.name = c_str(frames_.sensor_names[s]);
        const bool stamped = s < stamps.sensor_ns.size() && stamps.sensor_ns[s] > 0;
        p.stamp = to_ros_time(stamped ? stamps.sensor_ns[s] : stamps.frame_ns);
        p.transform = to_ros_transform(frame.T_root_sensor[s]);
        p.included = h.included;
        p.pose_valid = h.pose_valid;
        p.track_state = const_cast<char*>(core::to_string(h.state));
        p.fitness = h.fitness_reference;
    }
    poses_.sensors._buffer = sensor_poses_.data();
    poses_.sensors._length = poses_.sensors._maximum = static_cast<std::uint32_t>(n);
    poses_.sensors._release = false;
    return poses_;
}

DiagnosticsBuilder::DiagnosticsBuilder(StationFrames frames)
    : frames_(std::move(frames)), prefix_("lidarfuse/" + frames_.station + "/") {
    array_.header.frame_id = c_str(frames_.fused_frame);
}

void DiagnosticsBuilder::add(KeyValues* values, const char* key, std::string value) {
    strings_.push_back(std::move(value));
    values->push_back({const_cast<char*>(key), c_str(strings_.back())});
}

namespace {

constexpr std::uint8_t kOk = diagnostic_msgs_msg_dds__DiagnosticStatus_Constants_OK;
constexpr std::uint8_t kWarn = diagnostic_msgs_msg_dds__DiagnosticStatus_Constants_WARN;
constexpr std::uint8_t kError = diagnostic_msgs_msg_dds__DiagnosticStatus_Constants_ERROR;

std::string number(double v, const char* format = "%.3f") {
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), format, v);
    return buffer;
}

std::string value_of(const PipelineFigure& figure, const PipelineStats& stats) {
    if (figure.count) return std::to_string(stats.*figure.count);
    if (figure.measure) return number(stats.*figure.measure, figure.format);
    if (figure.text) return stats.*figure.text;
    return stats.*figure.flag ? "true" : "false";
}

// A sensor's level and message: ERROR when LOST, disagreeing with its metadata or without
// one, WARN when STALE or (`fusing`: frames were fused) without a pose.
std::pair<std::uint8_t, std::string> sensor_level(const SensorStats& s, bool fusing) {
    std::uint8_t level = kOk;
    std::string message = to_string(s.state);
    if (s.state == SensorState::kLost) {
        level = kError;
    } else if (s.state == SensorState::kModeMismatch) {
        level = kError;
        message += ": " + s.mode_seen;
    } else if (s.state == SensorState::kClockSkew) {
        level = kError;
        message += ": " + clock_skew_reason(s.clock_skew_ms);
    } else if (s.state == SensorState::kNoMetadata) {
        level = kError;
        if (!s.metadata.last_error.empty()) message += ": " + s.metadata.last_error;
    } else if (s.state == SensorState::kStale) {
        level = kWarn;
    }
    if (s.state != SensorState::kDisabled && fusing && !s.pose_valid) {
        level = std::max(level, kWarn);
        message += "; not registered";
    }
    return {level, std::move(message)};
}

}  // namespace

void DiagnosticsBuilder::set_status(diagnostic_msgs_msg_dds__DiagnosticStatus_* status,
                                    std::uint8_t level, std::string name, std::string message,
                                    std::string hardware_id) {
    status->level = level;
    strings_.push_back(std::move(name));
    status->name = c_str(strings_.back());
    strings_.push_back(std::move(message));
    status->message = c_str(strings_.back());
    strings_.push_back(std::move(hardware_id));
    status->hardware_id = c_str(strings_.back());
}

void DiagnosticsBuilder::add_sensor(diagnostic_msgs_msg_dds__DiagnosticStatus_* status,
                                    KeyValues* values, const SensorStats& s, bool fusing) {
    auto [level, message] = sensor_level(s, fusing);
    set_status(status, level, prefix_ + s.name, std::move(message), s.name);
    add_sensor_values(values, s);
}

void DiagnosticsBuilder::add_sensor_values(KeyValues* v, const SensorStats& s) {
    add(v, "state", to_string(s.state));
    for (const auto& counter : kSensorCounters)
        add(v, counter.name, std::to_string(s.*counter.member));
    add(v, "mode_seen", s.mode_seen);
    add(v, "metadata_source", s.metadata.source);
    add(v, "metadata_fetches", std::to_string(s.metadata.fetches));
    add(v, "metadata_fetch_failures", std::to_string(s.metadata.failures));
    add(v, "metadata_changes", std::to_string(s.metadata.changes));
    add(v, "metadata_configured", std::to_string(s.metadata.configured));
    add(v, "metadata_last_error", s.metadata.last_error);
    add(v, "completeness", number(s.last_completeness, "%.4f"));
    add(v, "ms_since_last_scan", number(s.ms_since_last_scan, "%.1f"));
    add(v, "clock_offset_ms", number(s.clock_offset_ms, "%.3f"));
    add(v, "clock_skew_ms", number(s.clock_skew_ms, "%.3f"));
    add(v, "offset_to_root_ms", number(s.offset_to_root_ms, "%.3f"));
    add(v, "track_state", s.track_state);
    add(v, "pose_valid", s.pose_valid ? "true" : "false");
    add(v, "fitness", number(s.fitness, "%.4f"));
    if (s.dds) add_dds_input_values(v, *s.dds);
}

// Only for a sensor whose clouds come from DDS; an Ouster sensor's keys stay as they were.
void DiagnosticsBuilder::add_dds_input_values(KeyValues* v, const DdsInputStatus& d) {
    add(v, "dds_topic", d.topic);
    add(v, "dds_domain_id", std::to_string(d.domain_id));
    add(v, "dds_publishers", std::to_string(d.publishers));
    add(v, "dds_clouds", std::to_string(d.clouds));
    add(v, "dds_clouds_refused", std::to_string(d.refused));
    add(v, "dds_non_finite_points", std::to_string(d.non_finite_points));
    add(v, "dds_frame_id", d.frame_id);
    add(v, "dds_last_error", d.last_error);
}

// WARN when packets or scans were dropped or the recording has a problem.
void DiagnosticsBuilder::add_pipeline(diagnostic_msgs_msg_dds__DiagnosticStatus_* status,
                                      KeyValues* values, const PipelineStats& stats) {
    const bool drops = stats.kernel_drops > 0 || stats.scan_queue_drops > 0;
    const std::string record_problem = stats.record.problem();
    set_status(status, drops || !record_problem.empty() ? kWarn : kOk, prefix_ + "pipeline",
               drops                    ? "packets or scans dropped"
               : record_problem.empty() ? "OK"
                                        : record_problem,
               frames_.station);
    for (const auto& figure : kPipelineFigures) add(values, figure.name, value_of(figure, stats));
    if (stats.record.enabled) add_record(values, stats.record);
    if (stats.foxglove.enabled) add_foxglove(values, stats.foxglove);
}

void DiagnosticsBuilder::add_record(KeyValues* v, const RecorderStats& r) {
    add(v, "record_state", r.recording ? "recording" : "stopped: " + r.stopped_because);
    add(v, "record_folder", r.folder);
    add(v, "record_file", r.file);
    add_counters(v, kRecorderCounters, r);
}

// The live view's clients, and per client (at most max_clients) what it was sent and what
// it lost to a full send buffer: "127.0.0.1:40312 sent 120 dropped 30".
void DiagnosticsBuilder::add_foxglove(KeyValues* values, const FoxgloveStats& f) {
    add(values, "foxglove_port", std::to_string(f.port));
    add(values, "foxglove_clients", std::to_string(f.clients.size()));
    add_counters(values, kFoxgloveCounters, f);
    for (std::size_t i = 0; i < f.clients.size(); ++i) {
        const auto& c = f.clients[i];
        strings_.push_back("foxglove_client_" + std::to_string(i));
        add(values, strings_.back().c_str(),
            c.peer + " sent " + std::to_string(c.sent) + " dropped " + std::to_string(c.dropped));
    }
}

void DiagnosticsBuilder::point_values() {
    for (std::size_t i = 0; i < status_.size(); ++i) {
        status_[i].values._buffer = values_[i].data();
        status_[i].values._length = status_[i].values._maximum =
            static_cast<std::uint32_t>(values_[i].size());
        status_[i].values._release = false;
    }
}

const diagnostic_msgs_msg_dds__DiagnosticArray_& DiagnosticsBuilder::build(
    const PipelineStats& stats, std::int64_t stamp_ns) {
    strings_.clear();
    values_.assign(stats.sensors.size() + 1, {});
    status_.assign(stats.sensors.size() + 1, diagnostic_msgs_msg_dds__DiagnosticStatus_{});
    for (std::size_t i = 0; i < stats.sensors.size(); ++i)
        add_sensor(&status_[i], &values_[i], stats.sensors[i], stats.frames_fused > 0);
    add_pipeline(&status_.back(), &values_.back(), stats);
    point_values();
    array_.header.stamp = to_ros_time(stamp_ns);
    point_sequence(&array_.status, status_);
    return array_;
}

}  // namespace lidarfuse::daemon

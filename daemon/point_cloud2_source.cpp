#include "daemon/point_cloud2_source.hpp"

#include <dds/dds.h>
#include <pthread.h>
#include <spdlog/spdlog.h>

#include <stdexcept>

#include "daemon/sensor_ingest.hpp"
#include "sensor_msgs.h"

namespace lidarfuse::daemon {

namespace {

std::string where(const PointCloud2SourceConfig& c) {
    return "source " + c.name + " (topic " + c.topic + ", domain " + std::to_string(c.domain_id) +
           ")";
}

// Fails with what Cyclone said, after deleting the participant (and all under it).
void check(dds_return_t rc, const char* what, dds_entity_t participant,
           const PointCloud2SourceConfig& config) {
    if (rc >= 0) return;
    if (participant > 0) dds_delete(participant);
    throw std::runtime_error("DDS: cannot create " + std::string(what) + " for " + where(config) +
                             ": " + dds_strretcode(rc));
}

}  // namespace

PointCloud2Source::PointCloud2Source(PointCloud2SourceConfig config, OnCloud on_cloud)
    : config_(std::move(config)), on_cloud_(std::move(on_cloud)) {
    participant_ =
        dds_create_participant(static_cast<dds_domainid_t>(config_.domain_id), nullptr, nullptr);
    check(participant_, "a participant", 0, config_);
    const dds_entity_t topic =
        dds_create_topic(participant_, &sensor_msgs_msg_dds__PointCloud2__desc,
                         config_.topic.c_str(), nullptr, nullptr);
    check(topic, "the topic", participant_, config_);
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, config_.depth);
    dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
    reader_ = dds_create_reader(participant_, topic, qos, nullptr);
    dds_delete_qos(qos);
    check(reader_, "a reader", participant_, config_);
    waitset_ = dds_create_waitset(participant_);
    check(waitset_, "a waitset", participant_, config_);
    const dds_entity_t readable = dds_create_readcondition(reader_, DDS_ANY_STATE);
    check(readable, "a read condition", participant_, config_);
    stop_condition_ = dds_create_guardcondition(participant_);
    check(stop_condition_, "a guard condition", participant_, config_);
    check(dds_waitset_attach(waitset_, readable, readable), "the waitset", participant_, config_);
    check(dds_waitset_attach(waitset_, stop_condition_, stop_condition_), "the waitset",
          participant_, config_);
}

PointCloud2Source::~PointCloud2Source() {
    stop();
    dds_delete(participant_);
}

void PointCloud2Source::start() {
    if (running_.exchange(true)) return;
    thread_ = std::thread([this] { run(); });
}

void PointCloud2Source::stop() {
    if (!running_.exchange(false)) return;
    dds_set_guardcondition(stop_condition_, true);
    if (thread_.joinable()) thread_.join();
}

void PointCloud2Source::run() {
    ::pthread_setname_np(::pthread_self(), "lf-dds-in");
    while (running_.load()) {
        const dds_return_t rc = dds_waitset_wait(waitset_, nullptr, 0, DDS_SECS(1));
        if (rc < 0) {
            spdlog::error("{}: waiting for clouds failed: {}", where(config_), dds_strretcode(rc));
            break;
        }
        if (!running_.load()) break;
        take_available();
    }
}

void PointCloud2Source::take_available() {
    constexpr int kBatch = 8;
    while (true) {
        void* samples[kBatch] = {};
        dds_sample_info_t infos[kBatch];
        const dds_return_t n = dds_take(reader_, samples, infos, kBatch, kBatch);
        if (n <= 0) return;
        for (int i = 0; i < n; ++i) {
            if (infos[i].valid_data) on_sample(samples[i]);
        }
        dds_return_loan(reader_, samples, n);
    }
}

void PointCloud2Source::on_sample(const void* sample) {
    const PointCloud2View view =
        view_of(*static_cast<const sensor_msgs_msg_dds__PointCloud2_*>(sample));
    const auto error = read_point_cloud2(view, &points_);
    {
        const std::lock_guard<std::mutex> lock(counters_mutex_);
        if (error) {
            ++counters_.refused;
            counters_.last_error = where(config_) + ": " + *error;
        } else {
            ++counters_.clouds;
            counters_.non_finite_points += points_.non_finite;
        }
    }
    if (error) return;
    on_cloud_({view.stamp_ns, realtime_ns(), view.frame_id, &points_});
}

PointCloud2SourceCounters PointCloud2Source::counters() const {
    const std::lock_guard<std::mutex> lock(counters_mutex_);
    return counters_;
}

int PointCloud2Source::publishers() const {
    dds_subscription_matched_status_t status{};
    if (dds_get_subscription_matched_status(reader_, &status) != DDS_RETCODE_OK) return 0;
    return static_cast<int>(status.current_count);
}

}  // namespace lidarfuse::daemon

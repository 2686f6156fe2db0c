#include "bench/dds_bench_reader.hpp"

#include <dds/dds.h>
#include <fcntl.h>
#include <sched.h>
#include <time.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "daemon/dds_messages.hpp"

namespace lidarfuse::bench {

std::int64_t monotonic_ns() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void subscribe(int domain, const Delivery& delivery, std::atomic<bool>* stop,
               std::atomic<bool>* matched, Received* out) {
    if (!delivery.reader_netns.empty()) {
        // Only this thread moves; the threads Cyclone starts from it follow it.
        const std::string path = "/var/run/netns/" + delivery.reader_netns;
        const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0 || ::setns(fd, CLONE_NEWNET) != 0) {
            std::fprintf(stderr, "daemon_latency_bench: cannot enter %s\n", path.c_str());
            std::exit(1);
        }
        ::close(fd);
    }
    const dds_entity_t participant =
        dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    dds_qos_t* qos = dds_create_qos();
    if (delivery.reader_reliable)
        dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    else
        dds_qset_reliability(qos, DDS_RELIABILITY_BEST_EFFORT, 0);
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, delivery.reader_depth);
    const auto reader = [&](const dds_topic_descriptor_t* type, const char* name) {
        const dds_entity_t topic = dds_create_topic(participant, type, name, nullptr, nullptr);
        return dds_create_reader(participant, topic, qos, nullptr);
    };
    const dds_entity_t points =
        reader(&sensor_msgs_msg_dds__PointCloud2__desc, "rt/lidarfuse/points");
    const dds_entity_t poses =
        reader(&lidarfuse_msgs_msg_dds__FramePoses__desc, "rt/lidarfuse/poses");
    const dds_entity_t diagnostics =
        reader(&diagnostic_msgs_msg_dds__DiagnosticArray__desc, "rt/diagnostics");
    dds_delete_qos(qos);
    const dds_entity_t waitset = dds_create_waitset(participant);
    for (dds_entity_t r : {points, poses, diagnostics}) {
        dds_waitset_attach(waitset, dds_create_readcondition(r, DDS_ANY_STATE), r);
    }
    while (!stop->load()) {
        dds_waitset_wait(waitset, nullptr, 0, DDS_MSECS(50));
        const std::int64_t now = monotonic_ns();
        dds_subscription_matched_status_t st{};
        dds_get_subscription_matched_status(points, &st);
        if (st.current_count > 0) matched->store(true);
        void* samples[8] = {};
        dds_sample_info_t infos[8];
        std::lock_guard<std::mutex> lock(out->mutex);
        dds_return_t n = dds_take(points, samples, infos, 8, 8);
        for (int i = 0; i < n; ++i) {
            if (!infos[i].valid_data) continue;
            const auto* m = static_cast<const sensor_msgs_msg_dds__PointCloud2_*>(samples[i]);
            out->cloud_arrival_ns.emplace(daemon::from_ros_time(m->header.stamp), now);
        }
        if (n > 0) dds_return_loan(points, samples, n);
        n = dds_take(poses, samples, infos, 8, 8);
        for (int i = 0; i < n; ++i) {
            if (!infos[i].valid_data) continue;
            const auto* m = static_cast<const lidarfuse_msgs_msg_dds__FramePoses_*>(samples[i]);
            auto& v = out->members[daemon::from_ros_time(m->header.stamp)];
            for (std::uint32_t s = 0; s < m->sensors._length; ++s) {
                const auto& p = m->sensors._buffer[s];
                v.push_back(p.included ? daemon::from_ros_time(p.stamp) : 0);
            }
        }
        if (n > 0) dds_return_loan(poses, samples, n);
        n = dds_take(diagnostics, samples, infos, 8, 8);
        for (int i = 0; i < n; ++i) {
            if (!infos[i].valid_data) continue;
            const auto* m =
                static_cast<const diagnostic_msgs_msg_dds__DiagnosticArray_*>(samples[i]);
            for (std::uint32_t s = 0; s < m->status._length; ++s) {
                const std::string name = m->status._buffer[s].name;
                auto& values = out->last_diagnostics[name];
                for (std::uint32_t k = 0; k < m->status._buffer[s].values._length; ++k) {
                    values[m->status._buffer[s].values._buffer[k].key] =
                        m->status._buffer[s].values._buffer[k].value;
                }
                const auto drops = values.find("frame_queue_drops");
                if (name.size() > 9 && name.compare(name.size() - 9, 9, "/pipeline") == 0 &&
                    drops != values.end()) {
                    out->queue_drops_over_time.emplace_back(now, std::stoull(drops->second));
                }
            }
        }
        if (n > 0) dds_return_loan(diagnostics, samples, n);
    }
    dds_delete(participant);
}

std::string diagnostic_value(Received* received, const std::string& status, const char* key) {
    std::lock_guard<std::mutex> lock(received->mutex);
    const auto values = received->last_diagnostics.find(status);
    if (values == received->last_diagnostics.end()) return "0";
    const auto it = values->second.find(key);
    return it == values->second.end() ? std::string("0") : it->second;
}

}  // namespace lidarfuse::bench

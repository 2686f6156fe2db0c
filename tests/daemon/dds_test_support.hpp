#pragma once
// Plain Cyclone DDS readers for the daemon's tests: loopback-only configuration, a domain
// id per test process (parallel ctest runs never hear each other), and a typed reader that
// takes samples with loans and hands them to a callback.

#include <dds/dds.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>

#include "tests/support/test_data.hpp"

namespace lidarfuse::test {

// Cyclone on the loopback interface only (it falls back to unicast discovery there), with
// room for the participants of parallel tests, large datagrams, and quiet logs. Must run
// before the first participant of the process; also inherited by child processes.
inline const char* const kLoopbackDdsConfig =
    "<General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
    "<MaxMessageSize>65500B</MaxMessageSize><FragmentSize>64000B</FragmentSize></General>"
    "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>40</MaxAutoParticipantIndex></Discovery>"
    "<Tracing><Verbosity>severe</Verbosity></Tracing>";

inline void use_loopback_dds() { ::setenv("CYCLONEDDS_URI", kLoopbackDdsConfig, 1); }

// 1..198, from this process's block of ports: distinct for the test processes alive.
inline int unique_domain_id() { return 1 + port_block_index(); }

// Reliable, keep-last `depth`, volatile unless asked; what a ROS 2 subscriber would use.
inline dds_qos_t* reader_qos(int depth, bool transient_local = false) {
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, depth);
    dds_qset_durability(qos,
                        transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
    return qos;
}

template <typename T>
class DdsReader {
public:
    // Takes ownership of `qos` (deleted here).
    DdsReader(dds_entity_t participant, const dds_topic_descriptor_t* type,
              const std::string& topic, dds_qos_t* qos) {
        topic_ = dds_create_topic(participant, type, topic.c_str(), nullptr, nullptr);
        if (topic_ < 0) throw std::runtime_error("topic " + topic + ": " + dds_strretcode(topic_));
        reader_ = dds_create_reader(participant, topic_, qos, nullptr);
        dds_delete_qos(qos);
        if (reader_ < 0)
            throw std::runtime_error("reader " + topic + ": " + dds_strretcode(reader_));
    }
    ~DdsReader() { dds_delete(reader_); }
    DdsReader(const DdsReader&) = delete;
    DdsReader& operator=(const DdsReader&) = delete;

    dds_entity_t reader() const { return reader_; }

    // Takes every available sample; returns how many were valid.
    int take(const std::function<void(const T&)>& on_sample) {
        int count = 0;
        while (true) {
            void* samples[16] = {};
            dds_sample_info_t infos[16];
            const dds_return_t n = dds_take(reader_, samples, infos, 16, 16);
            if (n <= 0) break;
            for (int i = 0; i < n; ++i) {
                if (!infos[i].valid_data) continue;
                on_sample(*static_cast<const T*>(samples[i]));
                ++count;
            }
            dds_return_loan(reader_, samples, n);
        }
        return count;
    }

    // Waits until a writer is matched (bounded; false when none came).
    bool wait_matched(int tries = 500) const {
        for (int i = 0; i < tries; ++i) {
            dds_subscription_matched_status_t st{};
            if (dds_get_subscription_matched_status(reader_, &st) == DDS_RETCODE_OK &&
                st.current_count > 0) {
                return true;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        return false;
    }

private:
    dds_entity_t topic_ = 0;
    dds_entity_t reader_ = 0;
};

// Polls `done` every 10 ms, at most `tries` times; true when it held.
inline bool eventually(const std::function<bool()>& done, int tries = 500) {
    for (int i = 0; i < tries; ++i) {
        if (done()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return done();
}

}  // namespace lidarfuse::test

#pragma once
// Wakes a consumer that reads several queues (the sync thread: one queue per receiver and
// per DDS source) when any of them gets an item, so that it sleeps until there is work or a
// deadline instead of looking at its queues every millisecond. Any thread may ring; one
// thread waits. A ring while nobody waits is kept for the next wait, so an item pushed
// between the consumer's last look at its queues and its wait is never slept through.

#include <chrono>
#include <condition_variable>
#include <mutex>

namespace lidarfuse::daemon {

class Doorbell {
public:
    void ring() {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            rung_ = true;
        }
        cv_.notify_one();
    }

    // Until the first ring since the previous return, or `deadline`; true when rung.
    bool wait_until(std::chrono::steady_clock::time_point deadline) {
        std::unique_lock<std::mutex> lock(mutex_);
        const bool rung = cv_.wait_until(lock, deadline, [this] { return rung_; });
        rung_ = false;
        return rung;
    }

private:
    std::mutex mutex_;
    std::condition_variable cv_;
    bool rung_ = false;
};

}  // namespace lidarfuse::daemon

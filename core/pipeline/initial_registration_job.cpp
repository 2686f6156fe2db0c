#include "core/pipeline/initial_registration_job.hpp"

#include <algorithm>
#include <exception>

#include "core/common/stopwatch.hpp"

namespace lidarfuse::core {

InitialRegistrationJob::InitialRegistrationJob(std::vector<PointCloud> clouds,
                                               const InitialRegistrationParams& params,
                                               int num_threads)
    : clouds_(std::move(clouds)),
      params_(params),
      num_threads_(std::max(1, num_threads)),
      num_clouds_(clouds_.size()) {
    params_.cancel = &cancel_;  // cancel() stops a running registration between its steps
}

void InitialRegistrationJob::run() {
    if (claimed_.exchange(true, std::memory_order_acq_rel)) return;  // already run or running
    if (cancelled()) {
        error_ = "cancelled before it started";
    } else {
        const Stopwatch run;
        try {
            result_ = register_initial(clouds_, params_, num_threads_);
        } catch (const std::exception& e) {
            // Allocation failure or a bug: the engine sees no registered sensor and retries
            // later, which beats taking the caller's thread down.
            result_ = InitialRegistrationResult{};
            error_ = e.what();
        }
        run_ms_ = run.milliseconds();
    }
    clouds_.clear();
    clouds_.shrink_to_fit();
    run_follow_up();
    done_.store(true, std::memory_order_release);
}

void InitialRegistrationJob::run_follow_up() {
    if (!follow_up_ || cancelled() || !error_.empty()) return;
    const Stopwatch follow_up;
    try {
        follow_up_(result_);
    } catch (const std::exception&) {
        // Allocation failure: what the follow-up did not finish, its caller does itself, as
        // without one (the engine starts the tracks it finds unstarted).
    }
    follow_up_ms_ = follow_up.milliseconds();
    follow_up_ = nullptr;  // what it holds is the engine's to keep, not the job's
}

}  // namespace lidarfuse::core

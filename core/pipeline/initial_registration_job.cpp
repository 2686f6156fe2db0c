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
    done_.store(true, std::memory_order_release);
}

}  // namespace lidarfuse::core

#pragma once
// One initial registration (PAPER.md steps 2-9) packaged so that it can run away from the
// fusion thread: FusionEngine::process() builds the job from a frame's scans, hands it out
// in FrameOutput::initial_job, and applies the result in a later process() call once done()
// is true. The caller decides where run() happens (a worker thread in lidarfused; inline in
// the engine when FusionParams::initial_registration_inline is set).
//
// Thread safety: run(), cancel(), done() and cancelled() may be called from any thread at
// any time. The job owns copies of its clouds, so it never touches the engine. result() may
// be read only after done() returned true (done() is an acquire of run()'s release). run()
// runs the registration at most once: a second or concurrent call returns at once.
// Cancellation is checked before the registration starts and, through
// InitialRegistrationParams::cancel, between its sensors and pairs: a cancelled job ends
// within one sensor's features or one pair's registration, with no sensor registered.

#include <atomic>
#include <cstddef>
#include <string>
#include <vector>

#include "core/common/point_cloud.hpp"
#include "core/initial/initial_registration.hpp"

namespace lidarfuse::core {

class InitialRegistrationJob {
public:
    // clouds[0] is the root's scan (the frame the poses are relative to), the others the
    // sensors to register; all in their own sensor frames.
    InitialRegistrationJob(std::vector<PointCloud> clouds, const InitialRegistrationParams& params,
                           int num_threads = 1);
    InitialRegistrationJob(const InitialRegistrationJob&) = delete;
    InitialRegistrationJob& operator=(const InitialRegistrationJob&) = delete;

    void run();
    void cancel() { cancel_.store(true, std::memory_order_release); }
    bool cancelled() const { return cancel_.load(std::memory_order_acquire); }
    // True once run() has finished (or returned early because the job was cancelled).
    bool done() const { return done_.load(std::memory_order_acquire); }

    // After done(): one entry per input cloud, in input order (none when cancelled before it
    // ran or when the registration threw; error() says which).
    const InitialRegistrationResult& result() const { return result_; }
    const std::string& error() const { return error_; }
    std::size_t num_clouds() const { return num_clouds_; }
    double run_ms() const { return run_ms_; }         // wall-clock time of the registration
    int num_threads() const { return num_threads_; }  // its OpenMP threads

private:
    std::vector<PointCloud> clouds_;
    InitialRegistrationParams params_;
    int num_threads_ = 1;
    std::size_t num_clouds_ = 0;
    InitialRegistrationResult result_;
    std::string error_;
    double run_ms_ = 0.0;
    std::atomic<bool> claimed_{false};
    std::atomic<bool> cancel_{false};
    std::atomic<bool> done_{false};
};

}  // namespace lidarfuse::core

#pragma once
// One initial registration (PAPER.md steps 2-9) packaged so that it can run away from the
// fusion thread: FusionEngine::process() builds the job from a frame's scans, hands it out
// in FrameOutput::initial_job, and applies the result in a later process() call once done()
// is true. The caller decides where run() happens (a worker thread in lidarfused; inline in
// the engine when FusionParams::initial_registration_inline is set).
//
// Thread safety: run(), cancel(), done() and cancelled() may be called from any thread at
// any time. The job owns copies of its clouds, so it never touches the engine (nor may its
// follow-up: it owns what it uses). result() may be read only after done() returned true
// (done() is an acquire of run()'s release). run() runs the registration at most once: a
// second or concurrent call returns at once.
// Cancellation is checked before the registration starts and, through
// InitialRegistrationParams::cancel, between its sensors and pairs: a cancelled job ends
// within one sensor's features or one pair's registration, with no sensor registered.

#include <atomic>
#include <cstddef>
#include <functional>
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

    // Work on the result that belongs away from the fusion thread as well (the engine starts
    // the registered sensors' tracks there): run() calls it on its own thread right after a
    // registration that did not throw and was not cancelled, before done(). Set before run().
    using FollowUp = std::function<void(const InitialRegistrationResult&)>;
    void set_follow_up(FollowUp follow_up) { follow_up_ = std::move(follow_up); }

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
    double run_ms() const { return run_ms_; }              // wall-clock time of the registration
    double follow_up_ms() const { return follow_up_ms_; }  // and of the follow-up after it
    int num_threads() const { return num_threads_; }       // its OpenMP threads

private:
    void run_follow_up();

    std::vector<PointCloud> clouds_;
    InitialRegistrationParams params_;
    int num_threads_ = 1;
    std::size_t num_clouds_ = 0;
    InitialRegistrationResult result_;
    std::string error_;
    double run_ms_ = 0.0;
    FollowUp follow_up_;
    double follow_up_ms_ = 0.0;
    std::atomic<bool> claimed_{false};
    std::atomic<bool> cancel_{false};
    std::atomic<bool> done_{false};
};

}  // namespace lidarfuse::core

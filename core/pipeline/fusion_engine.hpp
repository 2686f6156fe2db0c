#pragma once
// FusionEngine: synchronised frames in, every sensor's pose T_root_sensor and the fused
// cloud out (PAPER.md, continuous registration and dynamic objects), frame after frame.
//
//   first frame:  initial registration of every sensor against the root (feature based),
//                 as a job; until it is applied only the root is fused
//   every frame:  per sensor: predict (constant velocity) -> deskew (to the scan timestamp,
//                 the instant poses refer to) -> crop -> background model (dynamic points)
//                 -> voxel grid of the static points (grid fixed in the root frame)
//                 -> covariances
//                 G-ICP edges (PAPER.md's table):
//                   sensor vs its previous frame   init: the predicted motion
//                   sensor vs its reference frame  init: the current estimate (the paper
//                                                  uses identity; ours converges from
//                                                  closer and is never worse)
//                   sensor vs sensor, same frame   every k_w - 1 frames, and whenever a
//                                                  sensor was (re)initialised
//                 sliding-window pose graph (Ceres, Huber): nodes of the last k_w frames
//                 plus each sensor's reference frame; the root's reference is the gauge;
//                 reference nodes are optimised while in the window, fixed after
//   references:   on the first frame, and again once the reference scans are deskewed
//                 (their motion is known a few frames later; their poses are re-anchored
//                 to the scan timestamps and what was measured before leaves the graph),
//                 fine G-ICP edges (0.5 m voxels) between the reference frames: every later
//                 pose leans on them, and at the tracking voxel size edges between two
//                 viewpoints are biased. The reference target is kept at <= 1 m.
//   health:       a sensor whose reference edge keeps failing, or whose pose jumps, is
//                 registered again from scratch against the root, the others unaffected.
//
// Edge information: G-ICP's Hessian, calibrated so that whitened residuals are in sigmas
// (H * 3 / mean Mahalanobis error per correspondence: with the right covariance scale that
// mean is 3), which is what makes one Huber delta fit every edge.
//
// Initial registrations are handed out as jobs (FrameOutput::initial_job) for the caller to
// run on a thread of its choice, unless FusionParams::initial_registration_inline is set;
// see initial_registration_job.hpp. core/ starts no thread of its own.
//
// A caller that cannot keep up with the frame rate (lidarfused on a busy machine) may ask
// for a frame to be fused at its predicted poses instead (FrameMode::kPredict): each
// sensor's scan is deskewed, cropped and put through the background model, and placed at
// a constant-acceleration fit over its recent registered poses; no target, no edge, no
// solve. Registration goes on from the registered frames exactly as if the predicted ones
// had not been there, except that the background model has seen them. Where a frame must
// be registered (the root not tracked yet, an initial registration to apply, a sensor to
// register again, a sensor whose pose cannot be trusted to the fit: see
// FusionParams::prediction_*), kPredict registers it.
//
// Not thread safe: one thread calls process(). Internally it runs `num_threads` OpenMP
// threads over sensors and edges. Deterministic for a given input and thread count.

#include <cstdint>
#include <memory>
#include <vector>

#include "core/pipeline/fusion_types.hpp"
#include "core/pipeline/initial_registration_job.hpp"

namespace lidarfuse::core {

enum class FrameMode {
    kRegister,  // the continuous registration above
    kPredict,   // fused at the predicted poses, if the engine can (FrameOutput::registered)
};

class FusionEngine {
public:
    FusionEngine(std::size_t num_sensors, const FusionParams& params);
    ~FusionEngine();
    FusionEngine(const FusionEngine&) = delete;
    FusionEngine& operator=(const FusionEngine&) = delete;

    FrameOutput process(const FrameInput& frame, FrameMode mode = FrameMode::kRegister);
    // A fused cloud the caller is done with: the next frame's cloud is built in its
    // buffers (MBs at 100k+ points: allocated afresh, their pages are faulted in again).
    void recycle(FusedCloud cloud);

    const FusionParams& params() const;
    std::size_t num_sensors() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace lidarfuse::core

#pragma once
// FusionEngine's state and its steps, shared by the files that implement them (internal to
// core/pipeline; the interface is fusion_engine.hpp):
//   fusion_engine.cpp                  process(): one frame, steps 1-6, and steps 1-3
//   fusion_engine_graph.cpp            steps 4-6: the pose graph, poses and health, the
//                                      window, the fused cloud
//   fusion_engine_initialisation.cpp   initial registrations handed out and applied
//   fusion_engine_references.cpp       reference frames: deskew re-anchoring, fine edges,
//                                      removing a sensor's nodes
//   fusion_engine_prediction.cpp       a frame fused at its predicted poses (FrameMode)
// Not thread safe, like FusionEngine.

#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "core/common/stopwatch.hpp"
#include "core/graph/pose_graph.hpp"
#include "core/pipeline/fusion_engine.hpp"
#include "core/pipeline/initial_registration_job.hpp"
#include "core/pipeline/sensor_track.hpp"
#include "core/pipeline/sliding_window.hpp"

namespace lidarfuse::core {

// What the tracks of the sensors a job registers start from, and those tracks once its
// follow-up (InitialRegistrationJob::set_follow_up) has started them on the job's thread:
// the frame that applies the registration takes them over instead of starting them itself
// (hundreds of ms on the fusion thread). Shared by the engine and the job, which may
// outlive it. The engine writes T_root0_root only before it hands the job out.
struct TrackStarts {
    std::shared_ptr<const FusionParams> params;  // the tracks' (Impl::shared_params)
    std::vector<SensorScanInput> scans;          // the frame's scans, in the pending order
    Eigen::Isometry3d T_root0_root = Eigen::Isometry3d::Identity();  // root pose at the frame
    std::vector<std::unique_ptr<SensorTrack>> tracks;  // by position in the order; null: none

    // A new track of the sensor at position k of the order, started on its scan at the pose
    // `result` gives it.
    std::unique_ptr<SensorTrack> start(std::int64_t frame, std::size_t k,
                                       const InitialRegistrationResult& result,
                                       TrackScratch* scratch) const {
        auto track = std::make_unique<SensorTrack>(*params);
        track->start(frame, scans[k], T_root0_root * result.sensors[k].T_root_sensor, scratch);
        return track;
    }
};

// An initial registration handed out (or run inline) and what applying it needs.
struct PendingInitialisation {
    std::shared_ptr<InitialRegistrationJob> job;
    std::int64_t frame = 0;          // the frame of its scans
    bool first = false;              // the station's first registration
    std::vector<std::size_t> order;  // the root, then the sensors to register
    std::shared_ptr<TrackStarts> starts;
};

enum class EdgeKind { kPrevious, kReference, kInterSensor };

// One G-ICP edge of a frame: the source sensor's current scan against a target (its own
// previous or reference scan, or another sensor's current scan).
struct EdgeTask {
    EdgeKind kind;
    std::size_t source_sensor;
    std::size_t target_sensor;
    std::int64_t target_frame;
    const GicpCloud* target;
    const GicpCloud* source;
    Eigen::Isometry3d T_init;  // T_target_source
    GicpResult result;
    const std::vector<std::int32_t>* guess = nullptr;  // GicpRegistration::align
};

// What the steps of one process() call hand each other.
struct FrameWork {
    std::int64_t frame = 0;
    FrameOutput out;
    std::vector<char> usable;                  // the scan is there and holds enough points
    std::vector<std::size_t> started;          // sensors whose track started this frame
    std::vector<std::size_t> active;           // tracked sensors with a usable scan
    std::vector<Eigen::Isometry3d> predicted;  // T_root_sensor at this frame's scan
    bool reanchored = false;                   // a reference frame was re-anchored (deskew)
    std::vector<EdgeTask> tasks;               // step 3's edges, with their results
    std::vector<std::pair<PoseGraph::EdgeId, std::size_t>> edges;  // in the graph: edge, source

    bool is_started(std::size_t s) const {
        return std::find(started.begin(), started.end(), s) != started.end();
    }
};

struct FusionEngine::Impl {
    // Shared with a job's follow-up, which starts tracks on its own thread and may outlive
    // the engine.
    std::shared_ptr<const FusionParams> shared_params;
    const FusionParams& params;  // *shared_params
    std::size_t n;
    std::vector<std::unique_ptr<SensorTrack>> tracks;
    PoseGraph graph;
    std::vector<GicpRegistration> registrations;  // one per thread
    std::vector<TrackScratch> scratch;            // one per thread: what tracks prepare with
    std::int64_t frame_counter = 0;               // registered frames: the graph's frame index
    std::int64_t output_counter = 0;              // every frame: FrameOutput::frame_index
    // Each sensor's health in the last registered frame: a predicted frame reports its
    // registration figures.
    std::vector<SensorHealth> last_registered_health;
    std::int64_t last_retry_frame = -1'000'000;
    std::vector<int> suspicious;  // consecutive suspicious frames per sensor
    std::vector<bool> needs_reinit;
    SlidingWindow window;
    std::optional<PendingInitialisation> pending;
    std::vector<bool> started_first;  // this frame: started by the station's first registration
    // Deskew (FusionParams::deskew): edges measured between reference nodes in their own
    // frame (from skewed scans), removed when those references are deskewed; per sensor the
    // frame its reference was re-anchored (reference nodes stay free for a window after).
    struct ReferenceEdge {
        PoseGraph::EdgeId edge;
        std::size_t a, b;
    };
    std::vector<ReferenceEdge> reference_edges;
    std::vector<std::int64_t> reanchored_frame;
    std::optional<Eigen::Isometry3d> root_reanchor;  // left factor for the root's batch
    std::int64_t root_reanchor_reference = -1;       // the root reference frame it belongs to

    FusedCloud spare_cloud;  // FusionEngine::recycle's, for the next frame's cloud

    Impl(std::size_t num_sensors, const FusionParams& p);
    // A worker that has not begun the job yet can skip it; the job outlives the engine.
    ~Impl();

    FrameOutput process(const FrameInput& in);
    // FrameMode::kPredict (fusion_engine_prediction.cpp): every sensor's pose for this
    // frame when it can be fused at its predicted poses (nullopt: it must be registered),
    // and fusing it there.
    std::optional<std::vector<Eigen::Isometry3d>> predicted_poses(const FrameInput& in) const;
    // A scan that is there and holds enough points to register (FusionParams::min_scan_points).
    bool usable(const SensorScanInput& scan) const {
        return scan.present && scan.points.size() >= params.min_scan_points;
    }
    FrameOutput process_predicted(const FrameInput& in, std::vector<Eigen::Isometry3d> poses);
    void report_predicted_poses(FrameWork* w) const;
    // The calling thread's scratch (its number in the OpenMP team, 0 outside one).
    TrackScratch* thread_scratch();

    // The steps of process(), in order (fusion_engine.cpp, fusion_engine_graph.cpp). A
    // predicted frame takes no graph frame index (FrameWork::frame: the last registered).
    FrameWork begin_frame(const FrameInput& in, bool registered = true);
    bool initialise(const FrameInput& in, FrameWork* w);
    void reinitialise_due_sensors(const FrameInput& in, FrameWork* w);
    void prepare_tracks(const FrameInput& in, FrameWork* w);
    void register_edges(FrameWork* w);
    void plan_track_edges(FrameWork* w) const;
    void plan_inter_sensor_edges(FrameWork* w) const;
    void solve_graph(FrameWork* w);
    std::vector<PoseGraph::NodeId> add_edges(FrameWork* w);
    void report_poses(FrameWork* w);
    void report_edges(FrameWork* w) const;
    void detect_divergence(FrameWork* w);
    void slide_window(const FrameInput& in, const FrameWork& w);
    // Started on this very frame's scan (its reference): nothing to register this frame.
    bool is_fresh(const FrameWork& w, std::size_t s) const {
        return w.is_started(s) && tracks[s]->reference_frame() == w.frame;
    }

    // Starts an initial registration of `sensors` on this frame's scans, relative to the
    // root's pose at this frame (T_root0_root_now). Inline: runs and applies it at once.
    // Otherwise hands it out in out->initial_job; on the station's first frame the root
    // starts tracking right away (its pose is the identity by definition).
    void request_initialisation(std::int64_t frame, const FrameInput& in,
                                const std::vector<std::size_t>& sensors, bool first,
                                const Eigen::Isometry3d& T_root0_root_now,
                                std::vector<std::size_t>* started, FrameOutput* out);
    // Whether a sensor other than the root is tracked (then a job must leave fusion a core).
    bool tracking_beyond_root() const;
    // Starts the tracks of the sensors the finished job registered. Their reference frame is
    // the job's frame (its scans); when that is an earlier frame, they are tracked from this
    // frame on like any sensor (reference edge from the registered pose, inter-sensor edges).
    void apply_initialisation(std::int64_t frame, std::vector<std::size_t>* started,
                              FrameOutput* out);
    // Removes every graph node of sensor `s` (window and reference) and forgets its
    // reference edges (a sensor that diverged and is registered again).
    void remove_track_nodes(std::size_t s);
    // Deskews the reference scans whose motion is now known and re-anchors their poses to
    // the scan timestamps (SensorTrack::deskew_reference). The root goes first: its
    // correction changes the meaning of the root frame, so the sensors registered against
    // its reference get it as a left factor (sensors registered later, against a
    // not-yet-deskewed root frame, keep a residual of the root's motion over half a sweep).
    // Everything measured in the old meaning -- the sensor's window nodes and the edges
    // between reference frames -- leaves the graph. Returns whether any sensor re-anchored.
    bool reanchor_references(std::int64_t frame, const std::vector<char>& usable,
                             const std::vector<std::size_t>& started);
    // G-ICP between the reference scans of `sensors` (pairs whose references share a frame)
    // at the fine voxel size, as edges between their reference nodes (see
    // FusionParams::reference_voxel_size_m). One-off: a few hundred ms on 4 sensors.
    // Pairs: at least one of `fresh`, the other any sensor whose reference is final (deskew
    // on: deskewed) and shares the frame.
    void add_fine_reference_edges(const std::vector<std::size_t>& fresh, bool deskewed_only);
    // Step 6: the fused cloud of the active sensors, in the root frame (when asked for).
    void build_fused_cloud(FrameWork* w) const;
    void copy_fused_points(const std::vector<std::size_t>& active, FrameOutput* out) const;

    // G-ICP Hessian scaled so that whitened residuals are in sigmas (fusion_engine.hpp).
    Matrix6d calibrated_information(const GicpResult& r) const {
        const double scale = r.mean_error > 1e-12 ? 3.0 / r.mean_error : 1.0;
        return r.H * scale;
    }
};

}  // namespace lidarfuse::core

#pragma once
// Per-sensor background model (PAPER.md, "Dynamic objects"): change detection between the
// reference scan (frame 0) and the current one marks dynamic points; they raise a score in
// their voxel of a sparse 3-D grid in the reference sensor frame, and every frame all
// scores are attenuated, so only regions that keep changing (the lanes, the sidewalks)
// stay dynamic. The regions are 3-D voxels, not angular cells, so that the wall behind a
// passing truck is not condemned with it. Attenuation is applied lazily (score and the
// frame it was last raised), so a frame costs O(points), not O(cells). Registration then uses the
// points that are neither flagged now nor in a cell whose score is above the threshold.
//
// One object per sensor; not thread safe. Frames: everything in the reference sensor
// frame (the caller maps the current scan with its pose estimate T_{i,0}^{i,n-1}).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include "core/dynamics/change_detection.hpp"

namespace lidarfuse::core {

struct BackgroundModelParams {
    ChangeDetectionParams change;
    double attenuation = 0.9;  // score *= attenuation every frame
    double increment = 1.0;    // added to a cell per frame when a point in it changed
    double max_score = 10.0;
    double dynamic_threshold = 0.5;  // voxels above it are dynamic
    double voxel_size_m = 0.5;
};

struct BackgroundUpdate {
    std::vector<std::uint8_t> dynamic;            // per current point: 1 = dynamic
    std::vector<std::uint8_t> reference_dynamic;  // per reference point: removed since frame 0
    std::size_t num_dynamic = 0;
    std::size_t num_reference_dynamic = 0;
};

// What update() rebuilds for every frame and needs no longer: the change detection's
// scratch, the current points' voxel keys and their change flags. Shared by the models run
// one after another on one thread (see ChangeDetectionScratch).
struct BackgroundScratch {
    ChangeDetectionScratch detection;
    std::vector<std::uint64_t> current_keys;
    ChangeDetectionResult changes;
};

class BackgroundModel {
public:
    explicit BackgroundModel(const BackgroundModelParams& params = {});

    // `scratch`: the caller's, for the model's work on this thread; without one, the
    // model's own (made on first use).
    void set_reference(const std::vector<Eigen::Vector3d>& reference_points);
    void set_reference(const std::vector<Eigen::Vector3d>& reference_points,
                       BackgroundScratch* scratch);
    bool has_reference() const { return detector_.has_reference(); }

    // One frame: attenuate, detect changes, raise the scores of changed cells, classify.
    void update(const std::vector<Eigen::Vector3d>& current_in_reference_frame,
                BackgroundUpdate* out);
    void update(const std::vector<Eigen::Vector3d>& current_in_reference_frame,
                BackgroundUpdate* out, BackgroundScratch* scratch);

    double score_at(const Eigen::Vector3d& p_in_reference_frame) const;

private:
    struct Voxel {
        std::uint64_t key = 0;
        double score = 0.0;       // as of frame `frame`
        std::uint64_t frame = 0;  // last raised
    };
    std::uint64_t key_of(const Eigen::Vector3d& p) const;
    double score_of(std::uint64_t key) const;              // attenuated to the current frame
    double attenuation_after(std::uint64_t frames) const;  // params_.attenuation ^ frames
    void raise(std::uint64_t key);
    void mark_hot_voxels();  // fills hot_slots_, forgets faded voxels
    void forget(std::size_t i);
    bool maybe_hot(std::uint64_t key) const;
    BackgroundScratch* own_scratch();

    BackgroundModelParams params_;
    // 1 / voxel size where that is exact (a power of two: the default 0.5 m), else 0: key_of
    // runs on every point of every frame, and a division costs several multiplications.
    double inverse_voxel_size_ = 0.0;
    ChangeDetector detector_;
    // The voxels ever raised and not yet forgotten, contiguous so that mark_hot_voxels()
    // walks an array every frame, not a hash map's nodes; index_ finds a key's voxel.
    std::vector<Voxel> voxels_;
    std::unordered_map<std::uint64_t, std::uint32_t> index_;
    std::uint64_t frame_ = 0;
    std::size_t num_reference_ = 0;
    // Voxel keys (kNoKey: not finite) of the reference points, computed once.
    std::vector<std::uint64_t> reference_keys_;
    std::vector<double> attenuation_powers_;  // attenuation^k, k < size (std::pow values)
    // Per frame, one bit per hash slot of the voxels above the threshold: a point whose slot
    // is clear is below it without a lookup in voxels_ (most are: the dynamic regions are a
    // small part of a scan).
    std::vector<std::uint64_t> hot_slots_;
    // A voxel not raised for this many frames has attenuated below 1e-12 and is forgotten,
    // so that a station running for days keeps only the regions that still change.
    std::uint64_t forget_after_frames_ = 0;
    std::unique_ptr<BackgroundScratch> own_scratch_;
};

}  // namespace lidarfuse::core

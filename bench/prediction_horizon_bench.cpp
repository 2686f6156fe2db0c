// How far ahead a sensor's pose can be predicted from its registered poses (frames fused
// at predicted poses when the daemon is behind, FrameMode::kPredict): the error of each
// predictor against the simulator's truth, by the spacing and number of the registered
// poses it comes from and by the horizon.
//
// From the poses of `lidarfuse fuse` (every frame registered) and the simulator's truth:
// for each sensor and frame k, the registered poses at k, k - s, ..., k - (count - 1) s
// (stride s) predict the pose at k + ahead. Predictors: the mean body twist over three
// poses carried from the newest (the first kPredict), and core::extrapolate_pose's least-
// squares fits of order 1 and 2 (pose_extrapolation.hpp). Errors are taken against the
// truth mapped into the estimate's frame by each sensor's mean alignment over all frames,
// so they are what the registration or the prediction adds, not the choice of frame; the
// registered poses' own error is printed beside them.
//
// Output: `name value unit` lines, RMS over every sensor and frame:
//   registered_rot / _trans                                     the registered poses
//   mean_twist_stride<s>_count3_ahead<h>_rot / _trans           the mean twist
//   linear_fit_..., quadratic_fit_stride<s>_count<c>_ahead<h>_  the fits
// Usage: prediction_horizon_bench GROUND_TRUTH.csv POSES.csv [MAX_STRIDE [MAX_AHEAD]]

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <string>
#include <vector>

#include "core/common/se3.hpp"
#include "core/pipeline/pose_extrapolation.hpp"
#include "core/preprocess/deskew.hpp"
#include "drivers/io/pose_csv.hpp"

namespace {

using namespace lidarfuse;

constexpr double kNsToS = 1e-9;

struct Sample {
    std::int64_t t_ns = 0;
    Eigen::Isometry3d estimate;
    Eigen::Isometry3d truth;
};

// A sensor's estimated poses by frame, each with the truth nearest in time (within 25 ms).
using Track = std::map<std::int64_t, Sample>;

std::map<std::string, Track> matched_tracks(const core::Trajectories& truth,
                                            const core::Trajectories& estimate) {
    constexpr std::int64_t kTolerance = 25'000'000;
    std::map<std::string, Track> tracks;
    for (const auto& [sensor, samples] : estimate) {
        const auto gt = truth.find(sensor);
        if (gt == truth.end()) continue;
        for (const core::TrajectorySample& e : samples) {
            const core::TrajectorySample* best = nullptr;
            for (const core::TrajectorySample& g : gt->second) {
                if (std::llabs(g.t_ns - e.t_ns) > kTolerance) continue;
                if (!best || std::llabs(g.t_ns - e.t_ns) < std::llabs(best->t_ns - e.t_ns))
                    best = &g;
            }
            if (best) tracks[sensor][e.frame] = Sample{e.t_ns, e.pose, best->pose};
        }
    }
    return tracks;
}

// Per sensor, the transform C with estimate = C * truth, averaged over all frames: the
// errors below are then what registration or prediction adds, not the choice of frame.
Eigen::Isometry3d frame_alignment(const Track& track) {
    const Eigen::Isometry3d first =
        track.begin()->second.estimate * track.begin()->second.truth.inverse();
    core::Vector6d sum = core::Vector6d::Zero();
    for (const auto& [frame, s] : track)
        sum += core::se3_log(first.inverse() * s.estimate * s.truth.inverse());
    return first * core::se3_exp(sum / static_cast<double>(track.size()));
}

// Sums of squared errors (deg^2, m^2) and their count.
struct Rms {
    double rot2 = 0, trans2 = 0;
    std::size_t count = 0;
    void add(const Eigen::Isometry3d& pose, const Eigen::Isometry3d& true_pose) {
        const Eigen::Isometry3d e = pose.inverse() * true_pose;
        const double rot = core::rotation_angle_deg(Eigen::Matrix3d::Identity(), e.linear());
        rot2 += rot * rot;
        trans2 += e.translation().squaredNorm();
        ++count;
    }
    void print(const std::string& name) const {
        const double n = count > 0 ? static_cast<double>(count) : 1.0;
        std::printf("%s_rot %.5f deg\n", name.c_str(), std::sqrt(rot2 / n));
        std::printf("%s_trans %.6f m\n", name.c_str(), std::sqrt(trans2 / n));
    }
};

// The pose at `target` fitted to the registered poses `past` (oldest first) with
// core::extrapolate_pose, of order 1 or 2.
Eigen::Isometry3d fitted_pose(const std::vector<const Sample*>& past, const Sample& target,
                              int order) {
    std::vector<core::PoseSample> poses;
    for (const Sample* p : past) poses.push_back(core::PoseSample{0, p->t_ns, p->estimate});
    return core::extrapolate_pose(poses, target.t_ns, order);
}

// The earlier prediction: the mean body twist over the three poses' span, from the newest.
Eigen::Isometry3d mean_twist(const std::vector<const Sample*>& past, const Sample& target) {
    const Sample& first = *past.front();
    const Sample& last = *past.back();
    const double span_s = static_cast<double>(last.t_ns - first.t_ns) * kNsToS;
    const double ahead_s = static_cast<double>(target.t_ns - last.t_ns) * kNsToS;
    return last.estimate *
           core::se3_exp(core::body_twist_per_s(first.estimate, last.estimate, span_s) * ahead_s);
}

// Registered every `stride` frames, the last `count` of them; errors at `ahead` frames.
struct Variant {
    int stride, count, ahead;
    Rms mean, linear, quadratic;
};

void run(const std::map<std::string, Track>& tracks, int max_stride, int max_ahead) {
    std::vector<Variant> variants;
    for (int ahead = 1; ahead <= max_ahead; ++ahead)
        for (int stride = 1; stride <= max_stride; ++stride)
            for (int count : {3, 5, 9})
                variants.push_back(Variant{stride, count, ahead, {}, {}, {}});
    Rms registered;
    for (const auto& [sensor, track] : tracks) {
        const Eigen::Isometry3d C = frame_alignment(track);
        for (const auto& [k, last] : track) {
            registered.add(last.estimate, C * last.truth);
            for (Variant& v : variants) {
                const auto target = track.find(k + v.ahead);
                if (target == track.end()) continue;
                std::vector<const Sample*> past;
                for (int i = v.count - 1; i >= 0; --i) {
                    const auto p = track.find(k - i * v.stride);
                    if (p != track.end()) past.push_back(&p->second);
                }
                if (static_cast<int>(past.size()) != v.count) continue;
                const Eigen::Isometry3d truth = C * target->second.truth;
                if (v.count == 3) v.mean.add(mean_twist(past, target->second), truth);
                v.linear.add(fitted_pose(past, target->second, 1), truth);
                v.quadratic.add(fitted_pose(past, target->second, 2), truth);
            }
        }
    }
    registered.print("registered");
    for (const Variant& v : variants) {
        const std::string name = "_stride" + std::to_string(v.stride) + "_count" +
                                 std::to_string(v.count) + "_ahead" + std::to_string(v.ahead);
        if (v.count == 3) v.mean.print("mean_twist" + name);
        v.linear.print("linear_fit" + name);
        v.quadratic.print("quadratic_fit" + name);
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr,
                     "usage: prediction_horizon_bench GROUND_TRUTH.csv POSES.csv [MAX_STRIDE "
                     "[MAX_AHEAD]]\n");
        return 2;
    }
    try {
        const auto truth = io::to_trajectories(io::read_pose_csv(argv[1]));
        const auto estimate = io::to_trajectories(io::read_pose_csv(argv[2]));
        const int max_stride = argc > 3 ? std::atoi(argv[3]) : 4;
        const int max_ahead = argc > 4 ? std::atoi(argv[4]) : 6;
        if (max_stride < 1 || max_ahead < 1) {
            std::fprintf(stderr,
                         "prediction_horizon_bench: MAX_STRIDE and MAX_AHEAD must be >= 1\n");
            return 2;
        }
        run(matched_tracks(truth, estimate), max_stride, max_ahead);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "prediction_horizon_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}

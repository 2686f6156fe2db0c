#include "core/evaluation/evaluation.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "core/common/se3.hpp"

namespace lidarfuse::core {

namespace {

struct Match {
    const TrajectorySample* truth;
    const TrajectorySample* estimate;
};

bool all_timestamps_zero(const Trajectories& t) {
    for (const auto& [name, samples] : t) {
        for (const auto& s : samples) {
            if (s.t_ns != 0) return false;
        }
    }
    return true;
}

// Pairs each estimate sample with the ground-truth sample of the same sensor nearest in
// time (within tolerance), or with the same frame number when there are no timestamps.
std::vector<Match> match_samples(const std::vector<TrajectorySample>& truth,
                                 const std::vector<TrajectorySample>& estimate, bool by_frame,
                                 std::int64_t tolerance_ns) {
    std::vector<const TrajectorySample*> sorted;
    for (const auto& s : truth) sorted.push_back(&s);
    const auto key = [by_frame](const TrajectorySample* s) {
        return by_frame ? s->frame : s->t_ns;
    };
    std::sort(sorted.begin(), sorted.end(), [&](auto a, auto b) { return key(a) < key(b); });

    std::vector<Match> matches;
    for (const auto& e : estimate) {
        const std::int64_t k = by_frame ? e.frame : e.t_ns;
        auto it =
            std::lower_bound(sorted.begin(), sorted.end(), k,
                             [&](const TrajectorySample* s, std::int64_t v) { return key(s) < v; });
        const TrajectorySample* best = nullptr;
        std::int64_t best_gap = std::numeric_limits<std::int64_t>::max();
        for (auto c : {it, it == sorted.begin() ? it : it - 1}) {
            if (c == sorted.end()) continue;
            const std::int64_t gap = std::llabs(key(*c) - k);
            if (gap < best_gap) {
                best_gap = gap;
                best = *c;
            }
        }
        if (best && (by_frame ? best_gap == 0 : best_gap <= tolerance_ns)) {
            matches.push_back({best, &e});
        }
    }
    std::sort(matches.begin(), matches.end(), [](const Match& a, const Match& b) {
        return a.estimate->t_ns < b.estimate->t_ns ||
               (a.estimate->t_ns == b.estimate->t_ns && a.estimate->frame < b.estimate->frame);
    });
    return matches;
}

double rms(const std::vector<double>& v, std::size_t begin, std::size_t end) {
    if (end <= begin) return 0.0;
    double sum = 0;
    for (std::size_t i = begin; i < end; ++i) sum += v[i] * v[i];
    return std::sqrt(sum / static_cast<double>(end - begin));
}

// The estimated sensor whose earliest pose is nearest the frame's z axis (ties by the
// rotation from identity); empty when no sensor has a sample.
std::string nearest_root(const Trajectories& estimate) {
    std::string root;
    double best = std::numeric_limits<double>::infinity();
    for (const auto& [name, samples] : estimate) {
        if (samples.empty()) continue;
        const auto first = std::min_element(samples.begin(), samples.end(), [](auto& a, auto& b) {
            return a.t_ns < b.t_ns || (a.t_ns == b.t_ns && a.frame < b.frame);
        });
        const double d =
            first->pose.translation().head<2>().norm() +
            1e-6 * rotation_angle_deg(first->pose.rotation(), Eigen::Matrix3d::Identity());
        if (d < best) {
            best = d;
            root = name;
        }
    }
    return root;
}

// Per sensor with ground truth, its matched samples; and the positions of every match
// (estimate: root frame, truth: world frame), for the alignment.
struct MatchedSamples {
    std::map<std::string, std::vector<Match>> by_sensor;
    std::vector<Eigen::Vector3d> est_positions, gt_positions;
};

MatchedSamples match_all(const Trajectories& ground_truth, const Trajectories& estimate,
                         bool by_frame, std::int64_t tolerance_ns) {
    MatchedSamples matched;
    for (const auto& [name, samples] : estimate) {
        const auto gt = ground_truth.find(name);
        if (gt == ground_truth.end()) continue;
        auto m = match_samples(gt->second, samples, by_frame, tolerance_ns);
        for (const auto& p : m) {
            matched.est_positions.push_back(p.estimate->pose.translation());
            matched.gt_positions.push_back(p.truth->pose.translation());
        }
        matched.by_sensor[name] = std::move(m);
    }
    return matched;
}

// T_coord: Umeyama without scale from estimated to true positions. The positions must
// span a plane: with fewer than three sensors, or sensors along a line, the rotation
// about that line is not observable (pole sway alone is far too small to fix it), so
// T_coord maps the estimated root at its first match onto the true one instead (the
// strict metric's frame, whatever world.frame the estimate is in), and the result says so.
void align_to_world(const MatchedSamples& matched, const Eigen::Isometry3d& T_world_root0,
                    const Eigen::Isometry3d& T_root0_fused, EvaluationResult* result) {
    const std::vector<Eigen::Vector3d>& est_positions = matched.est_positions;
    const std::vector<Eigen::Vector3d>& gt_positions = matched.gt_positions;
    result->T_world_root = T_world_root0 * T_root0_fused;
    result->alignment = "root";
    if (est_positions.size() < 3) return;
    Eigen::Matrix3Xd src(3, est_positions.size()), dst(3, gt_positions.size());
    for (std::size_t i = 0; i < est_positions.size(); ++i) {
        src.col(static_cast<Eigen::Index>(i)) = est_positions[i];
        dst.col(static_cast<Eigen::Index>(i)) = gt_positions[i];
    }
    const Eigen::Vector3d mean = src.rowwise().mean();
    const Eigen::Matrix3d scatter = (src.colwise() - mean) * (src.colwise() - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
    // The middle spread (eigenvalues ascending) must be real geometry: at least 1 m rms
    // and 5% of the largest. Pole sway (tens of cm) never qualifies.
    const double count = static_cast<double>(est_positions.size());
    const double middle = eig.eigenvalues()(1), largest = eig.eigenvalues()(2);
    if (middle / count >= 1.0 && middle > 0.0025 * largest) {
        result->T_world_root = Eigen::Isometry3d(Eigen::umeyama(src, dst, false));
        result->alignment = "svd";
    }
}

// The transforms every sample's errors are measured with.
struct ErrorFrames {
    Eigen::Isometry3d T_world_root;   // aligned: the fitted T_coord (or root onto root)
    Eigen::Isometry3d T_world_root0;  // strict: the root's true pose at its first match
    Eigen::Isometry3d T_root0_fused;  // strict: the root's estimated pose there, inverted
};

// The sample's aligned and strict errors, appended to e's per-sample figures.
void add_sample_errors(const Match& m, const ErrorFrames& frames, SensorErrors* e) {
    const Eigen::Isometry3d aligned = frames.T_world_root * m.estimate->pose;
    const Eigen::Isometry3d strict_truth = frames.T_world_root0.inverse() * m.truth->pose;
    const Eigen::Isometry3d strict_estimate = frames.T_root0_fused * m.estimate->pose;
    e->t_ns.push_back(m.estimate->t_ns);
    e->trans_err_m.push_back((aligned.translation() - m.truth->pose.translation()).norm());
    e->rot_err_deg.push_back(rotation_angle_deg(aligned.rotation(), m.truth->pose.rotation()));
    e->strict_trans_err_m.push_back(
        (strict_estimate.translation() - strict_truth.translation()).norm());
    e->strict_rot_err_deg.push_back(
        rotation_angle_deg(strict_estimate.rotation(), strict_truth.rotation()));
}

// The sample's error in the estimate's own world frame (EvaluationParams::world), appended:
// kRoad: signed height (m) and up direction (deg); kGeo: translation (m) and rotation (deg)
// after the offset; kNone: nothing.
void add_world_errors(const Match& m, const EvaluationParams& params, std::vector<double>* trans,
                      std::vector<double>* rot) {
    if (params.world == EvaluationParams::World::kRoad) {
        const Eigen::Vector3d up_est = m.estimate->pose.linear().transpose().col(2);
        const Eigen::Vector3d up_gt = m.truth->pose.linear().transpose().col(2);
        trans->push_back(m.estimate->pose.translation().z() - m.truth->pose.translation().z());
        rot->push_back(std::atan2(up_est.cross(up_gt).norm(), up_est.dot(up_gt)) * 180.0 / M_PI);
    } else if (params.world == EvaluationParams::World::kGeo) {
        Eigen::Isometry3d est = m.estimate->pose;
        est.translation() += params.world_offset;
        trans->push_back((est.translation() - m.truth->pose.translation()).norm());
        rot->push_back(rotation_angle_deg(est.rotation(), m.truth->pose.rotation()));
    }
}

// Sums over the sensors with matched samples of their RMSEs, for the means; the world
// ones over the sensors with world errors.
struct ErrorSums {
    double trans_m = 0, rot_deg = 0;
    double strict_trans_m = 0, strict_rot_deg = 0;
    double world_trans_m = 0, world_rot_deg = 0;
};

// RMSEs and maxima of e's per-sample figures (at least one), and the drift figures.
void summarize(SensorErrors* e) {
    const std::size_t n = e->trans_err_m.size();
    e->rmse_trans_m = rms(e->trans_err_m, 0, n);
    e->rmse_rot_deg = rms(e->rot_err_deg, 0, n);
    e->strict_rmse_trans_m = rms(e->strict_trans_err_m, 0, n);
    e->strict_rmse_rot_deg = rms(e->strict_rot_err_deg, 0, n);
    e->max_trans_m = *std::max_element(e->trans_err_m.begin(), e->trans_err_m.end());
    e->max_rot_deg = *std::max_element(e->rot_err_deg.begin(), e->rot_err_deg.end());
    const std::size_t tenth = std::max<std::size_t>(1, n / 10);
    e->first_tenth_rmse_trans_m = rms(e->strict_trans_err_m, 0, tenth);
    e->last_tenth_rmse_trans_m = rms(e->strict_trans_err_m, n - tenth, n);
}

// One sensor's errors over its matched samples (num_truth: its ground-truth samples), added
// to the sums.
SensorErrors sensor_errors(const std::string& name, const std::vector<Match>& matches,
                           std::size_t num_truth, const ErrorFrames& frames,
                           const EvaluationParams& params, ErrorSums* sums) {
    SensorErrors e;
    e.sensor = name;
    e.matched = matches.size();
    e.missing = num_truth - std::min(num_truth, matches.size());
    if (matches.empty()) return e;
    std::vector<double> world_trans, world_rot;
    for (const auto& m : matches) {
        add_sample_errors(m, frames, &e);
        add_world_errors(m, params, &world_trans, &world_rot);
    }
    if (!world_trans.empty()) {
        e.world_rmse_trans_m = rms(world_trans, 0, world_trans.size());
        e.world_rmse_rot_deg = rms(world_rot, 0, world_rot.size());
        for (const double v : world_trans)
            e.world_max_trans_m = std::max(e.world_max_trans_m, std::abs(v));
        sums->world_trans_m += e.world_rmse_trans_m;
        sums->world_rot_deg += e.world_rmse_rot_deg;
    }
    summarize(&e);
    sums->trans_m += e.rmse_trans_m;
    sums->rot_deg += e.rmse_rot_deg;
    sums->strict_trans_m += e.strict_rmse_trans_m;
    sums->strict_rot_deg += e.strict_rmse_rot_deg;
    return e;
}

// The means over the sensors with matched samples.
void set_means(const ErrorSums& sums, EvaluationResult* result) {
    std::size_t with_samples = 0;
    for (const auto& s : result->sensors) with_samples += s.matched > 0 ? 1 : 0;
    const double count = static_cast<double>(with_samples);
    result->mean_rmse_trans_m = sums.trans_m / count;
    result->mean_rmse_rot_deg = sums.rot_deg / count;
    result->mean_strict_rmse_trans_m = sums.strict_trans_m / count;
    result->mean_strict_rmse_rot_deg = sums.strict_rot_deg / count;
    result->mean_world_rmse_trans_m = sums.world_trans_m / count;
    result->mean_world_rmse_rot_deg = sums.world_rot_deg / count;
}

}  // namespace

EvaluationResult evaluate_trajectories(const Trajectories& ground_truth,
                                       const Trajectories& estimate,
                                       const EvaluationParams& params) {
    EvaluationResult result;
    const bool by_frame = all_timestamps_zero(ground_truth) || all_timestamps_zero(estimate);
    result.root_sensor = params.root_sensor.empty() ? nearest_root(estimate) : params.root_sensor;

    const MatchedSamples matched =
        match_all(ground_truth, estimate, by_frame, params.match_tolerance_ns);
    const auto root = matched.by_sensor.find(result.root_sensor);
    if (root == matched.by_sensor.end() || root->second.empty()) {
        result.error = "no matched samples for the root sensor \"" + result.root_sensor + "\"";
        return result;
    }
    ErrorFrames frames;
    frames.T_world_root0 = root->second.front().truth->pose;
    frames.T_root0_fused = root->second.front().estimate->pose.inverse();
    align_to_world(matched, frames.T_world_root0, frames.T_root0_fused, &result);
    frames.T_world_root = result.T_world_root;

    ErrorSums sums;
    for (const auto& [name, matches] : matched.by_sensor) {
        result.sensors.push_back(
            sensor_errors(name, matches, ground_truth.at(name).size(), frames, params, &sums));
    }
    set_means(sums, &result);
    result.ok = true;
    return result;
}

}  // namespace lidarfuse::core

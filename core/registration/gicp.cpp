#include "core/registration/gicp.hpp"

#include <omp.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace lidarfuse::core {

const char* to_string(GicpStatus status) {
    switch (status) {
        case GicpStatus::kConverged:
            return "converged";
        case GicpStatus::kMaxIterations:
            return "max_iterations";
        case GicpStatus::kEmptyInput:
            return "empty_input";
        case GicpStatus::kMissingCovariances:
            return "missing_covariances";
        case GicpStatus::kTooFewCorrespondences:
            return "too_few_correspondences";
        case GicpStatus::kSingular:
            return "singular";
    }
    return "unknown";
}

// ---------------------------------------------------------------------------------------
// GicpTarget

GicpTarget::GicpTarget() : GicpTarget(PointCloud{}) {}

GicpTarget::GicpTarget(PointCloud cloud, int leaf_max_size)
    : cloud_(std::make_unique<PointCloud>(std::move(cloud))),
      tree_(std::make_unique<KdTree>(cloud_->points, leaf_max_size)) {}

GicpTarget::GicpTarget(PointCloud cloud, const NormalParams& covariances, int leaf_max_size)
    : cloud_(std::make_unique<PointCloud>(std::move(cloud))),
      tree_(std::make_unique<KdTree>(cloud_->points, leaf_max_size, covariances.num_threads)) {
    // Only the covariances and lists change, never the points the tree refers to.
    estimate_normals_covariances(cloud_.get(), *tree_, covariances);
}

GicpTarget::GicpTarget(GicpTarget&&) noexcept = default;
GicpTarget& GicpTarget::operator=(GicpTarget&&) noexcept = default;
GicpTarget::~GicpTarget() = default;

// ---------------------------------------------------------------------------------------
// Robust kernels on the squared Mahalanobis distance s: rho(s) and the IRLS weight rho'(s).

namespace {

struct Kernel {
    RobustKernel type;
    double c;   // scale
    double c2;  // scale^2

    double rho(double s) const {
        switch (type) {
            case RobustKernel::kNone:
                return s;
            case RobustKernel::kHuber:
                return s <= c2 ? s : 2.0 * c * std::sqrt(s) - c2;
            case RobustKernel::kGemanMcClure:
                return c2 * s / (c2 + s);
        }
        return s;
    }
    double weight(double s) const {
        switch (type) {
            case RobustKernel::kNone:
                return 1.0;
            case RobustKernel::kHuber:
                return s <= c2 ? 1.0 : c / std::sqrt(s);
            case RobustKernel::kGemanMcClure: {
                const double d = c2 + s;
                return c2 * c2 / (d * d);
            }
        }
        return 1.0;
    }
};

Kernel make_kernel(const GicpParams& p) {
    const double c = p.kernel_scale > 0.0 ? p.kernel_scale : 1.0;
    return Kernel{p.kernel, c, c * c};
}

}  // namespace

// ---------------------------------------------------------------------------------------
// GicpRegistration

void GicpRegistration::Linearization::add(const Linearization& o) {
    H += o.H;
    b += o.b;
    error += o.error;
    sum_sq_dist_m2 += o.sum_sq_dist_m2;
    num_inliers += o.num_inliers;
}

GicpRegistration::GicpRegistration(const GicpParams& params) : params_(params) {}

int GicpRegistration::num_threads() const { return std::max(1, params_.num_threads); }

namespace {

// (R^T C_B R + C_A)^-1 for plane covariances C = I - beta a a^T (point_cloud.hpp), given
// m = R^T a_B, a_A and 1 / beta of each cloud. With U = [m, a_A] the sum is
// 2 I - U diag(beta_B, beta_A) U^T, and by the Woodbury identity its inverse is
//   I / 2 + U K U^T / 4,   K = (diag(1 / beta_B, 1 / beta_A) - U^T U / 2)^-1.
// K's matrix has diagonal > 1/2 (0 < beta < 1, |axis| <= 1) and off-diagonal |m.a_A| / 2
// <= 1/2, so it is always invertible. About half the work of two congruences and an
// inverse, and the same matrix up to rounding.
Eigen::Matrix3d plane_pair_information(const Eigen::Vector3d& m, const Eigen::Vector3d& a,
                                       double inv_beta_b, double inv_beta_a) {
    const double p = inv_beta_b - 0.5 * m.squaredNorm();
    const double q = -0.5 * m.dot(a);
    const double r = inv_beta_a - 0.5 * a.squaredNorm();
    const double quarter_over_det = 0.25 / (p * r - q * q);
    const double k11 = r * quarter_over_det, k12 = -q * quarter_over_det;
    const double k22 = p * quarter_over_det;
    Eigen::Matrix3d N = k11 * m * m.transpose() + k22 * a * a.transpose();
    const Eigen::Matrix3d cross = k12 * m * a.transpose();
    N += cross + cross.transpose();
    N.diagonal().array() += 0.5;
    return N;
}

}  // namespace

void GicpRegistration::linearize(const GicpTarget& target, const PointCloud& source,
                                 const Eigen::Isometry3d& T, bool reuse_correspondences,
                                 Linearization* lin) {
    const std::size_t n = source.size();
    const int threads = num_threads();
    target_index_.resize(n);
    mahalanobis_.resize(n);
    // Zeroed every call: the team can be smaller than asked (nested inside another
    // parallel region), and unused slots must not keep an earlier call's sums.
    partial_.assign(static_cast<std::size_t>(threads), Linearization());
    const Kernel kernel = make_kernel(params_);
    const double max_d2 =
        params_.max_correspondence_distance_m * params_.max_correspondence_distance_m;
    const Eigen::Matrix3d R = T.linear();
    const Eigen::Vector3d t = T.translation();
    linearized_rotation_ = R;
    const auto& target_points = target.cloud().points;
    const auto& target_covs = target.cloud().covariances;
    const bool lists = target.cloud().has_neighbor_lists();
    const auto& neighbor_list = target.cloud().neighbor_list;
    const auto& neighbor_reach_d2 = target.cloud().neighbor_reach_d2;
    // Plane covariances on both sides: their pairs are inverted in closed form.
    const bool planes = target.cloud().has_plane_covariances() && source.has_plane_covariances();
    const auto& target_axes = target.cloud().covariance_axes;
    const auto& source_axes = source.covariance_axes;
    const double inv_beta_target = planes ? 1.0 / (1.0 - target.cloud().covariance_epsilon) : 0.0;
    const double inv_beta_source = planes ? 1.0 / (1.0 - source.covariance_epsilon) : 0.0;
    const Eigen::Matrix3d Rt = R.transpose();
    const long long count = static_cast<long long>(n);

#pragma omp parallel num_threads(threads) if (threads > 1)
    {
        Linearization local;
#pragma omp for schedule(static)
        for (long long i = 0; i < count; ++i) {
            const Eigen::Vector3d& a = source.points[i];
            const Eigen::Vector3d Ta = R * a + t;
            // Search bound: the correspondence limit, tightened to the previous neighbor's
            // distance (slightly inflated so that neighbor itself is still found).
            double bound = max_d2;
            std::uint32_t j = 0;
            double d2 = 0.0;
            bool certified = false;
            if (reuse_correspondences && target_index_[i] >= 0 &&
                static_cast<std::size_t>(target_index_[i]) < target_points.size()) {
                const auto prev = static_cast<std::size_t>(target_index_[i]);
                const double d2_prev = (target_points[prev] - Ta).squaredNorm();
                j = static_cast<std::uint32_t>(prev);
                d2 = d2_prev;
                if (lists) {
                    // The nearest of the previous neighbor and its listed neighbors is
                    // the nearest of all when it is closer than reach - |Ta - prev|: every
                    // unlisted point is at least that far (triangle inequality). The
                    // factor keeps rounding on the safe side.
                    const std::uint32_t* list =
                        &neighbor_list[prev * PointCloud::kNeighborListSize];
                    for (std::size_t r = 0; r < PointCloud::kNeighborListSize; ++r) {
                        const double d2_r = (target_points[list[r]] - Ta).squaredNorm();
                        if (d2_r < d2) {
                            d2 = d2_r;
                            j = list[r];
                        }
                    }
                    const double margin = std::sqrt(neighbor_reach_d2[prev]) - std::sqrt(d2_prev);
                    certified = margin > 0.0 && d2 < margin * margin * (1.0 - 1e-9);
                }
                if (!certified) bound = std::min(bound, d2 * (1.0 + 1e-9) + 1e-12);
            }
            if ((!certified && !target.tree().nearest_within(Ta, bound, &j, &d2)) || d2 > max_d2) {
                target_index_[i] = -1;
                continue;
            }
            // N = R^T M R = (R^T C_B R + C_A)^-1: M in the source frame, formed directly
            // (one congruence instead of two). Skip a correspondence whose combined
            // covariance is singular (only with unregularised, degenerate covariances).
            Eigen::Matrix3d N;
            if (planes) {
                N = plane_pair_information(Rt * target_axes[j], source_axes[i], inv_beta_target,
                                           inv_beta_source);
            } else {
                const Eigen::Matrix3d RCR = Rt * target_covs[j] * R + source.covariances[i];
                bool invertible = false;
                RCR.computeInverseWithCheck(N, invertible, 1e-12);
                if (!invertible) {
                    target_index_[i] = -1;
                    continue;
                }
            }
            target_index_[i] = static_cast<std::int32_t>(j);
            mahalanobis_[i] = N;

            // J = [R [a]x, -R] = R [A, -I] with A = [a]x (see the header), so with
            // d' = R^T d:
            //   J^T M J = [[-A N A, A N], [(A N)^T, N]],  J^T M d = [u x a, -u], u = N d'.
            // Cheaper than forming the 3x6 J (about half the multiply-adds), and the same
            // numbers up to rounding.
            const Eigen::Vector3d d = target_points[j] - Ta;
            const Eigen::Vector3d d_s = Rt * d;
            const Eigen::Vector3d u = N * d_s;
            const double s = d_s.dot(u);
            const double w = kernel.weight(s);
            Eigen::Matrix3d AN;  // A N: column k is a x N.col(k)
            for (int k = 0; k < 3; ++k) AN.col(k) = a.cross(N.col(k));
            Eigen::Matrix3d ANA;  // -A N A: row i is a x (row i of A N)
            for (int r = 0; r < 3; ++r) ANA.row(r) = a.cross(AN.row(r).transpose()).transpose();
            local.H.topLeftCorner<3, 3>().noalias() += w * ANA;
            local.H.topRightCorner<3, 3>().noalias() += w * AN;  // lower-left: its transpose
            local.H.bottomRightCorner<3, 3>().noalias() += w * N;
            local.b.head<3>() += w * u.cross(a);
            local.b.tail<3>() -= w * u;
            local.error += kernel.rho(s);
            local.sum_sq_dist_m2 += d2;
            ++local.num_inliers;
        }
        partial_[static_cast<std::size_t>(omp_get_thread_num())] = local;
    }
    // Fixed summation order: the result does not depend on thread timing.
    lin->reset();
    for (const auto& p : partial_) lin->add(p);
    // The same sums as accumulating the lower-left block itself, in the same order.
    lin->H.bottomLeftCorner<3, 3>() = lin->H.topRightCorner<3, 3>().transpose();
}

double GicpRegistration::evaluate(const GicpTarget& target, const PointCloud& source,
                                  const Eigen::Isometry3d& T) {
    const int threads = num_threads();
    partial_error_.assign(static_cast<std::size_t>(threads), 0.0);
    const Kernel kernel = make_kernel(params_);
    const auto& target_points = target.cloud().points;
    const Eigen::Matrix3d R_lin_t = linearized_rotation_.transpose();
    const long long count = static_cast<long long>(source.size());
#pragma omp parallel num_threads(threads) if (threads > 1)
    {
        double local = 0.0;
#pragma omp for schedule(static)
        for (long long i = 0; i < count; ++i) {
            const std::int32_t j = target_index_[i];
            if (j < 0) continue;
            // M held at the linearisation's rotation: d^T M d = d'^T N d', d' = R_lin^T d.
            const Eigen::Vector3d d_s = R_lin_t * (target_points[j] - T * source.points[i]);
            local += kernel.rho(d_s.dot(mahalanobis_[i] * d_s));
        }
        partial_error_[static_cast<std::size_t>(omp_get_thread_num())] = local;
    }
    double sum = 0.0;
    for (const double e : partial_error_) sum += e;
    return sum;
}

GicpResult GicpRegistration::align(const GicpTarget& target, const PointCloud& source,
                                   const Eigen::Isometry3d& T_init,
                                   const std::vector<std::int32_t>* guess) {
    GicpResult result;
    result.T_target_source = T_init;
    result.num_source = source.size();
    if (source.empty() || target.empty()) {
        result.status = GicpStatus::kEmptyInput;
        return result;
    }
    if (!source.has_covariances() || !target.cloud().has_covariances()) {
        result.status = GicpStatus::kMissingCovariances;
        return result;
    }

    const bool has_guess = guess && guess->size() == source.size();
    Eigen::Isometry3d T = T_init;
    Linearization lin;
    double lambda = params_.lm_initial_lambda;
    bool last_linearization_current = false;  // lin was computed at T
    result.status = GicpStatus::kMaxIterations;

    for (int iteration = 0; iteration < params_.max_iterations; ++iteration) {
        if (iteration == 0 && has_guess) target_index_ = *guess;
        linearize(target, source, T, /*reuse_correspondences=*/iteration > 0 || has_guess, &lin);
        last_linearization_current = true;
        if (lin.num_inliers < params_.min_correspondences) {
            result.status = GicpStatus::kTooFewCorrespondences;
            break;
        }
        Vector6d delta = Vector6d::Zero();
        bool stop = false;
        if (params_.solver == GicpSolver::kGaussNewton) {
            delta = lin.H.ldlt().solve(-lin.b);
            if (!delta.allFinite()) {
                result.status = GicpStatus::kSingular;
                break;
            }
            T = T * se3_exp(delta);
            last_linearization_current = false;
        } else {
            // Levenberg-Marquardt: accept the damped step only if the robust error over
            // the current correspondences decreases.
            bool accepted = false;
            for (int inner = 0; inner < params_.lm_max_inner_iterations; ++inner) {
                const Matrix6d A = lin.H + lambda * Matrix6d::Identity();
                delta = A.ldlt().solve(-lin.b);
                if (!delta.allFinite()) break;
                const Eigen::Isometry3d T_new = T * se3_exp(delta);
                if (evaluate(target, source, T_new) <= lin.error) {
                    T = T_new;
                    last_linearization_current = false;
                    lambda = std::max(lambda * 0.1, 1e-12);
                    accepted = true;
                    break;
                }
                lambda *= 10.0;
            }
            if (!delta.allFinite()) {
                result.status = GicpStatus::kSingular;
                break;
            }
            // No step lowers the error even with heavy damping: T is a local minimum for
            // these correspondences, which do not change when T does not.
            if (!accepted) stop = true;
        }
        result.iterations = iteration + 1;
        const bool small_update = delta.head<3>().norm() < params_.rotation_eps_rad &&
                                  delta.tail<3>().norm() < params_.translation_eps_m;
        if (stop || small_update) {
            result.status = GicpStatus::kConverged;
            break;
        }
    }

    // Report H, error and inliers at the final T. After a converged step the last
    // linearisation is at most one sub-threshold step away; otherwise linearise again.
    if (!last_linearization_current && result.status != GicpStatus::kConverged) {
        // The loop's correspondences (if it ran) are this source's: reuse them as bounds.
        linearize(target, source, T, /*reuse_correspondences=*/params_.max_iterations > 0, &lin);
    }
    result.converged = result.status == GicpStatus::kConverged;
    result.T_target_source = T;
    result.num_inliers = lin.num_inliers;
    result.inlier_ratio =
        static_cast<double>(lin.num_inliers) / static_cast<double>(result.num_source);
    result.error = lin.error;
    if (lin.num_inliers > 0) {
        result.mean_error = lin.error / static_cast<double>(lin.num_inliers);
        result.rmse_m = std::sqrt(lin.sum_sq_dist_m2 / static_cast<double>(lin.num_inliers));
        const double dof = 3.0 * static_cast<double>(lin.num_inliers) - 6.0;
        result.reduced_chi2 = dof > 0.0 ? lin.error / dof : 0.0;
    }
    result.H = 0.5 * (lin.H + lin.H.transpose());  // remove summation asymmetry
    result.b = lin.b;
    if (result.H.allFinite()) {
        Eigen::SelfAdjointEigenSolver<Matrix6d> eig(result.H, Eigen::EigenvaluesOnly);
        result.H_eigenvalues = eig.eigenvalues();
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig_t(result.H.bottomRightCorner<3, 3>(),
                                                             Eigen::EigenvaluesOnly);
        result.H_translation_eigenvalues = eig_t.eigenvalues();
    }
    return result;
}

GicpResult align_gicp(const GicpTarget& target, const PointCloud& source,
                      const Eigen::Isometry3d& T_init, const GicpParams& params) {
    GicpRegistration registration(params);
    return registration.align(target, source, T_init);
}

}  // namespace lidarfuse::core

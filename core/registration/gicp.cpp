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

GicpRegistration::GicpRegistration(const GicpParams& params, int num_threads)
    : params_(params), num_threads_(std::max(1, num_threads)) {}

namespace {

// (R^T C_B R + C_A)^-1 for plane covariances C = I - beta a a^T (normals.hpp), given
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

// The target side of the correspondence search, read-only for one linearize() call.
struct CorrespondenceSearch {
    const KdTree& tree;
    const std::vector<Eigen::Vector3d>& points;
    const std::vector<std::uint32_t>& neighbor_list;  // kListSize per point
    const std::vector<double>& neighbor_reach_d2;     // m^2
    bool lists;                                       // the two above are filled
    double max_d2;                                    // correspondence limit (m^2)
};

CorrespondenceSearch make_search(const GicpCloud& target, double max_distance_m) {
    const CovarianceByproducts& byproducts = target.byproducts();
    return CorrespondenceSearch{target.tree(),
                                target.points(),
                                byproducts.neighbor_list,
                                byproducts.reach_d2,
                                target.has_neighbor_lists(),
                                max_distance_m * max_distance_m};
}

// The nearest of the previous neighbor `prev` and its listed neighbors, in *j and *d2
// (m^2). True (certified) when it is the nearest of all: it is closer than
// reach - |Ta - prev|, and every unlisted point is at least that far (triangle
// inequality). The factor keeps rounding on the safe side.
inline bool nearest_listed(const CorrespondenceSearch& search, const Eigen::Vector3d& Ta,
                           std::size_t prev, std::uint32_t* j, double* d2) {
    const double d2_prev = (search.points[prev] - Ta).squaredNorm();
    *j = static_cast<std::uint32_t>(prev);
    *d2 = d2_prev;
    if (!search.lists) return false;
    constexpr std::size_t kList = CovarianceByproducts::kListSize;
    const std::uint32_t* list = &search.neighbor_list[prev * kList];
    for (std::size_t r = 0; r < kList; ++r) {
        const double d2_r = (search.points[list[r]] - Ta).squaredNorm();
        if (d2_r < *d2) {
            *d2 = d2_r;
            *j = list[r];
        }
    }
    const double margin = std::sqrt(search.neighbor_reach_d2[prev]) - std::sqrt(d2_prev);
    return margin > 0.0 && *d2 < margin * margin * (1.0 - 1e-9);
}

// The nearest target point to Ta within the correspondence limit, in *j and *d2 (m^2);
// false when there is none. `prev` (-1: none) is the previous correspondence: the search
// bound is tightened to its candidate's distance, slightly inflated so that the candidate
// itself is still found.
inline bool find_correspondence(const CorrespondenceSearch& search, const Eigen::Vector3d& Ta,
                                std::int32_t prev, std::uint32_t* j, double* d2) {
    double bound = search.max_d2;
    *j = 0;
    *d2 = 0.0;
    bool certified = false;
    if (prev >= 0 && static_cast<std::size_t>(prev) < search.points.size()) {
        certified = nearest_listed(search, Ta, static_cast<std::size_t>(prev), j, d2);
        if (!certified) bound = std::min(bound, *d2 * (1.0 + 1e-9) + 1e-12);
    }
    if (!certified && !search.tree.nearest_within(Ta, bound, j, d2)) return false;
    return !(*d2 > search.max_d2);
}

// The covariances of both clouds, read-only for one linearize() call at rotation R.
struct PairCovariances {
    const Eigen::Matrix3d& R;
    const Eigen::Matrix3d& Rt;
    const GicpCloud& target;
    const GicpCloud& source;
    // Plane covariances on both sides: their pairs are inverted in closed form.
    bool planes;
    const std::vector<Eigen::Vector3d>& target_axes;
    const std::vector<Eigen::Vector3d>& source_axes;
    double inv_beta_target;  // 1 / (1 - epsilon); 0 without planes
    double inv_beta_source;
};

PairCovariances make_pair_covariances(const GicpCloud& target, const GicpCloud& source,
                                      const Eigen::Matrix3d& R, const Eigen::Matrix3d& Rt) {
    const bool planes = target.has_plane_covariances() && source.has_plane_covariances();
    const CovarianceByproducts& tb = target.byproducts();
    const CovarianceByproducts& sb = source.byproducts();
    return PairCovariances{R,
                           Rt,
                           target,
                           source,
                           planes,
                           tb.plane_axes,
                           sb.plane_axes,
                           planes ? 1.0 / (1.0 - tb.plane_epsilon) : 0.0,
                           planes ? 1.0 / (1.0 - sb.plane_epsilon) : 0.0};
}

// N = R^T M R = (R^T C_B R + C_A)^-1 of source point i and target point j: M in the source
// frame, formed directly (one congruence instead of two). False when the combined
// covariance is singular (only with unregularised, degenerate covariances).
inline bool pair_information(const PairCovariances& c, std::size_t i, std::uint32_t j,
                             Eigen::Matrix3d* N) {
    if (c.planes) {
        *N = plane_pair_information(c.Rt * c.target_axes[j], c.source_axes[i], c.inv_beta_target,
                                    c.inv_beta_source);
        return true;
    }
    const Eigen::Matrix3d RCR = c.Rt * c.target.covariance(j) * c.R + c.source.covariance(i);
    bool invertible = false;
    RCR.computeInverseWithCheck(*N, invertible, 1e-12);
    return invertible;
}

// Adds w J^T M J to H and w J^T M d to b for source point a. J = [R [a]x, -R] = R [A, -I]
// with A = [a]x (see the header), so with d' = R^T d:
//   J^T M J = [[-A N A, A N], [(A N)^T, N]],  J^T M d = [u x a, -u], u = N d'.
// Cheaper than forming the 3x6 J (about half the multiply-adds), and the same numbers up to
// rounding. The lower-left block of H is left to the caller (the transpose of the
// upper-right one).
inline void add_normal_equations(const Eigen::Vector3d& a, const Eigen::Matrix3d& N,
                                 const Eigen::Vector3d& u, double w, Matrix6d* H, Vector6d* b) {
    Eigen::Matrix3d AN;  // A N: column k is a x N.col(k)
    for (int k = 0; k < 3; ++k) AN.col(k) = a.cross(N.col(k));
    Eigen::Matrix3d ANA;  // -A N A: row i is a x (row i of A N)
    for (int r = 0; r < 3; ++r) ANA.row(r) = a.cross(AN.row(r).transpose()).transpose();
    H->topLeftCorner<3, 3>().noalias() += w * ANA;
    H->topRightCorner<3, 3>().noalias() += w * AN;
    H->bottomRightCorner<3, 3>().noalias() += w * N;
    b->head<3>() += w * u.cross(a);
    b->tail<3>() -= w * u;
}

}  // namespace

int GicpRegistration::team_size(std::size_t points, std::size_t min_points_per_thread) const {
    const std::size_t useful = std::max<std::size_t>(1, points / min_points_per_thread);
    return static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(num_threads_), useful));
}

void GicpRegistration::linearize(const GicpCloud& target, const GicpCloud& source,
                                 const Eigen::Isometry3d& T, bool reuse_correspondences,
                                 Linearization* lin) {
    const std::size_t n = source.size();
    const int threads = team_size(n, kLinearizePointsPerThread);
    target_index_.resize(n);
    mahalanobis_.resize(n);
    // Zeroed every call: the team can be smaller than asked (nested inside another
    // parallel region), and unused slots must not keep an earlier call's sums.
    partial_.assign(static_cast<std::size_t>(threads), Linearization());
    const Kernel kernel = make_kernel(params_);
    const Eigen::Matrix3d R = T.linear();
    const Eigen::Vector3d t = T.translation();
    linearized_rotation_ = R;
    const Eigen::Matrix3d Rt = R.transpose();
    const CorrespondenceSearch search = make_search(target, params_.max_correspondence_distance_m);
    const PairCovariances covariances = make_pair_covariances(target, source, R, Rt);
    const std::vector<Eigen::Vector3d>& source_points = source.points();
    const long long count = static_cast<long long>(n);

#pragma omp parallel num_threads(threads) if (threads > 1)
    {
        Linearization local;
#pragma omp for schedule(static)
        for (long long i = 0; i < count; ++i) {
            const Eigen::Vector3d& a = source_points[i];
            const Eigen::Vector3d Ta = R * a + t;
            const std::int32_t prev = reuse_correspondences ? target_index_[i] : -1;
            std::uint32_t j = 0;
            double d2 = 0.0;
            Eigen::Matrix3d N;
            if (!find_correspondence(search, Ta, prev, &j, &d2) ||
                !pair_information(covariances, static_cast<std::size_t>(i), j, &N)) {
                target_index_[i] = -1;
                continue;
            }
            target_index_[i] = static_cast<std::int32_t>(j);
            mahalanobis_[i] = N;
            const Eigen::Vector3d d = search.points[j] - Ta;
            const Eigen::Vector3d d_s = Rt * d;
            const Eigen::Vector3d u = N * d_s;
            const double s = d_s.dot(u);
            add_normal_equations(a, N, u, kernel.weight(s), &local.H, &local.b);
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

double GicpRegistration::evaluate(const GicpCloud& target, const GicpCloud& source,
                                  const Eigen::Isometry3d& T) {
    const int threads = team_size(source.size(), kEvaluatePointsPerThread);
    partial_error_.assign(static_cast<std::size_t>(threads), 0.0);
    const Kernel kernel = make_kernel(params_);
    const auto& target_points = target.points();
    const auto& source_points = source.points();
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
            const Eigen::Vector3d d_s = R_lin_t * (target_points[j] - T * source_points[i]);
            local += kernel.rho(d_s.dot(mahalanobis_[i] * d_s));
        }
        partial_error_[static_cast<std::size_t>(omp_get_thread_num())] = local;
    }
    double sum = 0.0;
    for (const double e : partial_error_) sum += e;
    return sum;
}

namespace {

// kEmptyInput or kMissingCovariances when the pair cannot be registered, else
// kMaxIterations: the status of a run that no other condition ends.
GicpStatus input_status(const GicpCloud& target, const GicpCloud& source) {
    if (source.empty() || target.empty()) return GicpStatus::kEmptyInput;
    if (!source.has_covariances() || !target.has_covariances()) {
        return GicpStatus::kMissingCovariances;
    }
    return GicpStatus::kMaxIterations;
}

bool is_small_update(const Vector6d& delta, const GicpParams& params) {
    return delta.head<3>().norm() < params.rotation_eps_rad &&
           delta.tail<3>().norm() < params.translation_eps_m;
}

// The error figures of the result from the sums over its inlier correspondences.
void report_error(double error, double sum_sq_dist_m2, std::size_t num_inliers,
                  GicpResult* result) {
    result->num_inliers = num_inliers;
    result->inlier_ratio =
        static_cast<double>(num_inliers) / static_cast<double>(result->num_source);
    result->error = error;
    if (num_inliers > 0) {
        result->mean_error = error / static_cast<double>(num_inliers);
        result->rmse_m = std::sqrt(sum_sq_dist_m2 / static_cast<double>(num_inliers));
        const double dof = 3.0 * static_cast<double>(num_inliers) - 6.0;
        result->reduced_chi2 = dof > 0.0 ? error / dof : 0.0;
    }
}

// H (symmetrised), b and H's spectra (ascending) into the result.
void report_information(const Matrix6d& H, const Vector6d& b, GicpResult* result) {
    result->H = 0.5 * (H + H.transpose());  // remove summation asymmetry
    result->b = b;
    if (result->H.allFinite()) {
        Eigen::SelfAdjointEigenSolver<Matrix6d> eig(result->H, Eigen::EigenvaluesOnly);
        result->H_eigenvalues = eig.eigenvalues();
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig_t(result->H.bottomRightCorner<3, 3>(),
                                                             Eigen::EigenvaluesOnly);
        result->H_translation_eigenvalues = eig_t.eigenvalues();
    }
}

}  // namespace

bool GicpRegistration::levenberg_marquardt_step(const GicpCloud& target, const GicpCloud& source,
                                                const Linearization& lin, double* lambda,
                                                Eigen::Isometry3d* T, Vector6d* delta) {
    for (int inner = 0; inner < params_.lm_max_inner_iterations; ++inner) {
        const Matrix6d A = lin.H + *lambda * Matrix6d::Identity();
        *delta = A.ldlt().solve(-lin.b);
        if (!delta->allFinite()) return false;
        const Eigen::Isometry3d T_new = *T * se3_exp(*delta);
        if (evaluate(target, source, T_new) <= lin.error) {
            *T = T_new;
            *lambda = std::max(*lambda * 0.1, 1e-12);
            return true;
        }
        *lambda *= 10.0;
    }
    return false;
}

GicpResult GicpRegistration::align(const GicpCloud& target, const GicpCloud& source,
                                   const Eigen::Isometry3d& T_init,
                                   const std::vector<std::int32_t>* guess) {
    GicpResult result;
    result.T_target_source = T_init;
    result.num_source = source.size();
    result.status = input_status(target, source);
    if (result.status != GicpStatus::kMaxIterations) return result;

    const bool has_guess = guess && guess->size() == source.size();
    Eigen::Isometry3d T = T_init;
    Linearization lin;
    double lambda = params_.lm_initial_lambda;
    bool last_linearization_current = false;  // lin was computed at T
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
            if (delta.allFinite()) T = T * se3_exp(delta);
        } else {
            // No step lowers the error even with heavy damping: T is a local minimum for
            // these correspondences, which do not change when T does not.
            stop = !levenberg_marquardt_step(target, source, lin, &lambda, &T, &delta);
        }
        if (!delta.allFinite()) {
            result.status = GicpStatus::kSingular;
            break;
        }
        last_linearization_current = stop;  // T has moved unless the LM step found none
        result.iterations = iteration + 1;
        if (stop || is_small_update(delta, params_)) {
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
    report_error(lin.error, lin.sum_sq_dist_m2, lin.num_inliers, &result);
    report_information(lin.H, lin.b, &result);
    return result;
}

GicpResult align_gicp(const GicpCloud& target, const GicpCloud& source,
                      const Eigen::Isometry3d& T_init, const GicpParams& params, int num_threads) {
    GicpRegistration registration(params, num_threads);
    return registration.align(target, source, T_init);
}

}  // namespace lidarfuse::core

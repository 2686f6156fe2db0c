#pragma once
// Generalized-ICP (Segal, Haehnel, Thrun 2009), written on our KdTree.
//
// Finds T = T_target_source minimising, over correspondences (a_i in source, b_i its
// nearest neighbor in the target within max_correspondence_distance_m),
//   E(T) = sum_i rho( d_i^T M_i d_i ),   d_i = b_i - T a_i,
//   M_i = (C^B_i + R C^A_i R^T)^-1        (Segal eq. 2; C from normals.hpp, regularised)
// with rho a robust kernel (identity by default).
//
// Linearisation (right perturbation, T <- T * exp(delta), delta = [omega; v] as in se3.hpp):
//   T exp(delta) a ~= R (a + omega x a + v) + t = T a + R (-[a]x omega + v)
//   => d_i(delta) ~= d_i + J_i delta,  J_i = [ R [a_i]x , -R ]      (3x6)
// Gauss-Newton normal equations with M_i held fixed at the current R:
//   H = sum w_i J_i^T M_i J_i,  b = sum w_i J_i^T M_i d_i,  (H + lambda I) delta = -b
// where w_i = rho'(s_i) is the IRLS weight. Correspondences are searched again at every
// iteration; the Levenberg-Marquardt variant accepts a step only if it lowers E over the
// same correspondences (cheap: no k-d tree search) and adapts lambda.
//
// H at the solution is the information matrix of T in this tangent order and frame (the
// pose-graph edge information; see pose_graph.hpp). Its scale follows the unitless
// covariances: it is relative information, not calibrated metres^-2. H, b, error and the
// inlier count come from the last linearisation: at the returned T, or (when converged)
// at most one sub-threshold step before it, which saves a k-d tree pass per call.
//
// Correspondence search, exact and cheaper than a fresh k-d tree search per point: from the
// second linearisation on, a source point looks at its previous neighbor j and j's listed
// neighbors (the target's CovarianceByproducts, filled by the covariances' k-NN). The nearest of
// them is the nearest of all when it is closer than reach(j) - |Ta - j|, since every
// unlisted point is at least that far (triangle inequality); otherwise the k-d tree is
// searched, bounded by that candidate's distance. What it saves, and why the list holds 8:
// bench/BENCHMARK.md ("Measured behind the defaults").
//
// M_i in closed form: when both clouds carry plane covariances with their axes
// (gicp_cloud.hpp), C = I - beta a a^T, and the inverse of the pair's sum is a rank-2
// Woodbury update of I / 2 (gicp.cpp), instead of two congruences and a 3x3 inverse.
//
// Threading: the per-iteration reduction runs with up to the registration's `num_threads`
// OpenMP threads (a constructor argument, not a parameter of the method; a small source
// wakes fewer, see team_size()), each with
// its own H, b and error sums, added at the end in a fixed order (results do not depend on
// scheduling beyond floating-point summation order per thread block, which is static).
// num_threads = 1 runs serially without touching the OpenMP pool. On a loaded machine,
// libgomp's default active spin-waiting makes 2 threads far slower than 1 (bench/BENCHMARK.md,
// "Measured behind the defaults"); processes that pass num_threads > 1
// should run with OMP_WAIT_POLICY=passive (it is read at program start).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/se3.hpp"
#include "core/registration/gicp_cloud.hpp"

namespace lidarfuse::core {

enum class RobustKernel {
    kNone,
    kHuber,        // rho(s) = s for sqrt(s) <= c, else 2 c sqrt(s) - c^2
    kGemanMcClure  // rho(s) = c^2 s / (c^2 + s)
};

enum class GicpSolver { kGaussNewton, kLevenbergMarquardt };

struct GicpParams {
    double max_correspondence_distance_m = 1.0;
    int max_iterations = 30;
    // Converged when the update is below both (translation in m, rotation in rad).
    double translation_eps_m = 1e-4;
    double rotation_eps_rad = 1e-4;
    RobustKernel kernel = RobustKernel::kNone;
    // Kernel scale c, in Mahalanobis units (sqrt of d^T M d).
    double kernel_scale = 1.0;
    GicpSolver solver = GicpSolver::kLevenbergMarquardt;
    double lm_initial_lambda = 1e-4;
    int lm_max_inner_iterations = 10;
    // Fewer correspondences than this: not converged, status kTooFewCorrespondences.
    std::size_t min_correspondences = 10;
};

enum class GicpStatus {
    kConverged,
    kMaxIterations,          // stopped at max_iterations; T is the last estimate
    kEmptyInput,             // empty source or target
    kMissingCovariances,     // source or target has no covariances
    kTooFewCorrespondences,  // at the initial guess or during the iterations
    kSingular                // H could not be solved (rank deficient even with damping)
};

const char* to_string(GicpStatus status);

struct GicpResult {
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    bool converged = false;
    GicpStatus status = GicpStatus::kEmptyInput;
    int iterations = 0;
    std::size_t num_source = 0;
    std::size_t num_inliers = 0;  // correspondences within the distance bound at T
    double inlier_ratio = 0.0;    // num_inliers / num_source (the "fitness")
    double error = 0.0;           // sum of (robust) squared Mahalanobis distances at T
    double mean_error = 0.0;      // error / num_inliers
    double rmse_m = 0.0;          // Euclidean RMSE of the inlier correspondences at T (m)
    // error / (3 * num_inliers - 6): the residual scale in Mahalanobis units. The
    // covariance shapes are unitless, so H alone is relative information; H / reduced_chi2
    // is the usual variance-calibrated information (covariance ~ reduced_chi2 * H^-1),
    // should a caller want edges of different scans weighted on one scale.
    double reduced_chi2 = 0.0;
    Matrix6d H = Matrix6d::Zero();  // Hessian (information) at T, order [omega; v]
    Vector6d b = Vector6d::Zero();
    // Eigenvalues of H, ascending (conditioning / degeneracy check: the smallest collapses
    // when a direction is unconstrained, e.g. sliding along a single plane).
    Vector6d H_eigenvalues = Vector6d::Zero();
    // Eigenvalues of the translation block of H (ascending). Rotation and translation have
    // different units, so the full spectrum mixes rad^-2 and m^-2; the translation block
    // alone is the cleaner degeneracy figure (e.g. smallest / largest ~ epsilon of the
    // covariance regularisation when the scene is a single plane).
    Eigen::Vector3d H_translation_eigenvalues = Eigen::Vector3d::Zero();
};

// Reusable registration: keeps per-correspondence and per-thread buffers between calls,
// so a frame loop does not allocate once the buffers have grown. One object per thread.
class GicpRegistration {
public:
    explicit GicpRegistration(const GicpParams& params = {}, int num_threads = 1);
    const GicpParams& params() const { return params_; }
    void set_params(const GicpParams& params) { params_ = params; }

    // Aligns `source` (needs covariances) to `target`, starting from T_init.
    // `guess` (may be null; else one entry per source point): a likely correspondence of
    // each source point (target index, -1 for none), e.g. where it was in the previous
    // frame. It only bounds the first iteration's search, which stays exact (see
    // linearize()), so it changes the time, never the result.
    GicpResult align(const GicpCloud& target, const GicpCloud& source,
                     const Eigen::Isometry3d& T_init = Eigen::Isometry3d::Identity(),
                     const std::vector<std::int32_t>* guess = nullptr);
    // After align(): each source point's correspondence at the last linearisation (target
    // index, -1 for none); a guess for the next frame's alignment to the same target.
    const std::vector<std::int32_t>& correspondences() const { return target_index_; }

private:
    // Sums over the correspondences at one pose (also the per-thread partial sums).
    struct Linearization {
        Matrix6d H = Matrix6d::Zero();
        Vector6d b = Vector6d::Zero();
        double error = 0.0;           // robust
        double sum_sq_dist_m2 = 0.0;  // Euclidean, for rmse_m
        std::size_t num_inliers = 0;
        void reset() { *this = Linearization(); }
        void add(const Linearization& o);
    };
    // Correspondence search + H, b, error at T (correspondences kept in the buffers).
    // reuse_correspondences: target_index_ holds this source's neighbors from the
    // previous iteration of the same align() (or the caller's guess); the distance to that
    // neighbor bounds the search (exact: the nearest can only be closer), which prunes
    // most of the k-d tree.
    void linearize(const GicpCloud& target, const GicpCloud& source, const Eigen::Isometry3d& T,
                   bool reuse_correspondences, Linearization* lin);
    // Robust error over the stored correspondences at T (no k-d tree search).
    double evaluate(const GicpCloud& target, const GicpCloud& source, const Eigen::Isometry3d& T);
    // One Levenberg-Marquardt step over lin's correspondences: tries damped steps from
    // *lambda up (updating it) and takes the first that lowers the robust error (*T moved,
    // true). False when none does; *delta is then the last step tried (maybe not finite).
    bool levenberg_marquardt_step(const GicpCloud& target, const GicpCloud& source,
                                  const Linearization& lin, double* lambda, Eigen::Isometry3d* T,
                                  Vector6d* delta);
    // How many of num_threads_ to wake for a pass over `points` source points: no more than
    // give each thread min_points_per_thread. Waking a sleeping team (OMP_WAIT_POLICY=passive)
    // costs about what one thread spends on a few thousand points of linearize(), and on
    // several times as many of evaluate(), which does less per point (bench/BENCHMARK.md,
    // "G-ICP beside small_gicp").
    int team_size(std::size_t points, std::size_t min_points_per_thread) const;
    static constexpr std::size_t kLinearizePointsPerThread = 2048;
    static constexpr std::size_t kEvaluatePointsPerThread = 8192;
    GicpParams params_;
    int num_threads_ = 1;                     // at least 1
    std::vector<std::int32_t> target_index_;  // per source point, -1 = no correspondence
    // Per source point, M_i at the last linearisation in the source frame at its rotation:
    // N_i = R^T M_i R (evaluate() rotates the residuals back with linearized_rotation_).
    std::vector<Eigen::Matrix3d> mahalanobis_;
    Eigen::Matrix3d linearized_rotation_ = Eigen::Matrix3d::Identity();
    std::vector<Linearization> partial_;  // per thread
    std::vector<double> partial_error_;   // per thread
};

// One-off convenience wrapper (allocates its buffers).
GicpResult align_gicp(const GicpCloud& target, const GicpCloud& source,
                      const Eigen::Isometry3d& T_init, const GicpParams& params = {},
                      int num_threads = 1);

}  // namespace lidarfuse::core

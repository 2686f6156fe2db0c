#pragma once
// Pose-graph optimisation with Ceres (PAPER.md: initial registration step 9 and the
// continuous sliding window).
//
// Nodes: poses T_world_node (Isometry3d), keyed by a caller-chosen 64-bit id, stored as an
// Eigen quaternion (EigenQuaternionManifold) plus a Euclidean translation. Edges: measured
// relative poses T_a_b (e.g. a G-ICP T_target_source with a = target, b = source) with a 6x6
// information matrix in the se3.hpp tangent order [omega; v], right perturbation of T_a_b
// (exactly G-ICP's H). The residual is in relative_pose_error.hpp. Each edge gets a Huber
// loss (delta in whitened units, i.e. "sigmas") unless huber_delta <= 0.
//
// Build and solve are separate: add/remove nodes and edges, then optimize(). The
// ceres::Problem lives as long as the PoseGraph and is edited in place (Ceres' fast removal
// is enabled, so removing a node or an edge costs O(its edges)), and the node values are
// kept between solves, so a sliding window is: add the new frame's nodes (initial pose
// from the last estimate) and edges, remove the nodes that leave the window (their edges
// go with them), optimize() -- warm started from the previous solution, never rebuilt.
//
// Gauge: any node can be held constant (set_node_fixed). If no node is fixed, optimize()
// fixes none and the solution floats (the caller is expected to fix the root).
//
// Not thread safe; optimize() may use `num_threads` Ceres threads internally.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/common/se3.hpp"

namespace ceres {
class Problem;
class Manifold;
class LossFunction;
class CostFunction;
}  // namespace ceres

namespace lidarfuse::core {

struct PoseGraphParams {
    double huber_delta = 1.0;  // whitened residual norm where Huber turns linear; <= 0: none
    int max_iterations = 50;
    double function_tolerance = 1e-8;
    double gradient_tolerance = 1e-10;
    double parameter_tolerance = 1e-10;
};

struct PoseGraphSummary {
    bool usable = false;     // ceres::Solver::Summary::IsSolutionUsable()
    bool converged = false;  // termination_type == CONVERGENCE
    int iterations = 0;
    double initial_cost = 0.0;
    double final_cost = 0.0;
    std::size_t num_nodes = 0;
    std::size_t num_edges = 0;
    std::string message;  // Ceres' one-line report (or why nothing was solved)
};

// After optimisation: how well an edge agrees with the poses.
struct EdgeResidual {
    double chi2 = 0.0;           // |S log(T_a_b^-1 T_a^-1 T_b)|^2, whitened
    double robust_weight = 1.0;  // Huber IRLS weight at chi2 (1 inside delta, < 1 beyond)
    double translation_m = 0.0;  // unwhitened translation / rotation disagreement
    double rotation_deg = 0.0;
};

class PoseGraph {
public:
    using NodeId = std::int64_t;
    using EdgeId = std::int64_t;

    explicit PoseGraph(const PoseGraphParams& params = {});
    ~PoseGraph();
    PoseGraph(const PoseGraph&) = delete;
    PoseGraph& operator=(const PoseGraph&) = delete;

    // Adds a node at T_world_node. Returns false (and changes nothing) if the id exists.
    bool add_node(NodeId id, const Eigen::Isometry3d& T_world_node, bool fixed = false);
    // Removes the node and every edge touching it. False if unknown.
    bool remove_node(NodeId id);
    bool has_node(NodeId id) const;
    bool set_node_fixed(NodeId id, bool fixed);
    bool set_node_pose(NodeId id, const Eigen::Isometry3d& T_world_node);
    std::optional<Eigen::Isometry3d> node_pose(NodeId id) const;
    std::vector<NodeId> node_ids() const;

    // Adds the measurement T_a_b with its information (6x6, symmetric positive definite,
    // order [omega; v]). Returns the edge id, or -1 if a node is missing, a == b, or the
    // information is not positive definite (LLT fails) or not finite.
    EdgeId add_edge(NodeId a, NodeId b, const Eigen::Isometry3d& T_a_b,
                    const Matrix6d& information);
    bool remove_edge(EdgeId id);
    std::size_t num_nodes() const { return nodes_.size(); }
    std::size_t num_edges() const { return edges_.size(); }

    // Solves with the current values as the starting point.
    PoseGraphSummary optimize(int num_threads = 1);

    // The edge's disagreement at the current node values (after optimize(): the residual).
    std::optional<EdgeResidual> edge_residual(EdgeId id) const;

private:
    struct Node;
    struct Edge;
    PoseGraphParams params_;
    std::unique_ptr<ceres::Problem> problem_;
    std::unique_ptr<ceres::Manifold> quaternion_manifold_;
    std::unique_ptr<ceres::LossFunction> loss_;
    std::map<NodeId, std::unique_ptr<Node>> nodes_;
    std::map<EdgeId, std::unique_ptr<Edge>> edges_;
    EdgeId next_edge_id_ = 0;
};

}  // namespace lidarfuse::core

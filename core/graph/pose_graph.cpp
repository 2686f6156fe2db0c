#include "core/graph/pose_graph.hpp"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <set>

#include "core/graph/relative_pose_error.hpp"

namespace lidarfuse::core {

// Parameter storage must not move while the Problem refers to it: nodes live behind
// unique_ptr in the map.
struct PoseGraph::Node {
    double q[4] = {0.0, 0.0, 0.0, 1.0};  // x, y, z, w (Eigen order)
    double t[3] = {0.0, 0.0, 0.0};
    bool fixed = false;
    std::set<EdgeId> edges;

    void set(const Eigen::Isometry3d& T) {
        const Eigen::Quaterniond quat = quaternion_of(T);
        q[0] = quat.x();
        q[1] = quat.y();
        q[2] = quat.z();
        q[3] = quat.w();
        t[0] = T.translation().x();
        t[1] = T.translation().y();
        t[2] = T.translation().z();
    }
    Eigen::Isometry3d get() const {
        return isometry_from_quaternion(Eigen::Quaterniond(q[3], q[0], q[1], q[2]),
                                        Eigen::Vector3d(t[0], t[1], t[2]));
    }
};

struct PoseGraph::Edge {
    NodeId a = 0;
    NodeId b = 0;
    Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
    Matrix6d sqrt_information = Matrix6d::Identity();
    std::unique_ptr<ceres::CostFunction> cost;
    ceres::ResidualBlockId block = nullptr;
};

PoseGraph::PoseGraph(const PoseGraphParams& params)
    : params_(params), quaternion_manifold_(std::make_unique<ceres::EigenQuaternionManifold>()) {
    if (params_.huber_delta > 0.0) loss_ = std::make_unique<ceres::HuberLoss>(params_.huber_delta);
    ceres::Problem::Options options;
    // Removal in O(edges of the block) instead of O(problem): the sliding window removes
    // the oldest nodes every frame.
    options.enable_fast_removal = true;
    // PoseGraph owns cost functions, the loss and the manifold (shared by all nodes).
    options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_ = std::make_unique<ceres::Problem>(options);
}

PoseGraph::~PoseGraph() {
    // The Problem refers to node storage and edge cost functions: destroy it first.
    problem_.reset();
}

bool PoseGraph::add_node(NodeId id, const Eigen::Isometry3d& T_world_node, bool fixed) {
    if (nodes_.count(id) != 0) return false;
    auto node = std::make_unique<Node>();
    node->set(T_world_node);
    problem_->AddParameterBlock(node->q, 4, quaternion_manifold_.get());
    problem_->AddParameterBlock(node->t, 3);
    nodes_.emplace(id, std::move(node));
    set_node_fixed(id, fixed);
    return true;
}

bool PoseGraph::remove_node(NodeId id) {
    auto it = nodes_.find(id);
    if (it == nodes_.end()) return false;
    const std::set<EdgeId> edges = it->second->edges;  // remove_edge edits the set
    for (const EdgeId e : edges) remove_edge(e);
    problem_->RemoveParameterBlock(it->second->q);
    problem_->RemoveParameterBlock(it->second->t);
    nodes_.erase(it);
    return true;
}

bool PoseGraph::has_node(NodeId id) const { return nodes_.count(id) != 0; }

bool PoseGraph::set_node_fixed(NodeId id, bool fixed) {
    auto it = nodes_.find(id);
    if (it == nodes_.end()) return false;
    Node& node = *it->second;
    node.fixed = fixed;
    if (fixed) {
        problem_->SetParameterBlockConstant(node.q);
        problem_->SetParameterBlockConstant(node.t);
    } else {
        problem_->SetParameterBlockVariable(node.q);
        problem_->SetParameterBlockVariable(node.t);
    }
    return true;
}

bool PoseGraph::set_node_pose(NodeId id, const Eigen::Isometry3d& T_world_node) {
    auto it = nodes_.find(id);
    if (it == nodes_.end()) return false;
    it->second->set(T_world_node);
    return true;
}

std::optional<Eigen::Isometry3d> PoseGraph::node_pose(NodeId id) const {
    auto it = nodes_.find(id);
    if (it == nodes_.end()) return std::nullopt;
    return it->second->get();
}

std::vector<PoseGraph::NodeId> PoseGraph::node_ids() const {
    std::vector<NodeId> ids;
    ids.reserve(nodes_.size());
    for (const auto& [id, node] : nodes_) ids.push_back(id);
    return ids;
}

PoseGraph::EdgeId PoseGraph::add_edge(NodeId a, NodeId b, const Eigen::Isometry3d& T_a_b,
                                      const Matrix6d& information) {
    auto it_a = nodes_.find(a);
    auto it_b = nodes_.find(b);
    if (a == b || it_a == nodes_.end() || it_b == nodes_.end()) return -1;
    if (!information.allFinite() || !T_a_b.matrix().allFinite()) return -1;
    const Matrix6d symmetric = 0.5 * (information + information.transpose());
    Eigen::LLT<Matrix6d> llt(symmetric);
    if (llt.info() != Eigen::Success) return -1;

    auto edge = std::make_unique<Edge>();
    edge->a = a;
    edge->b = b;
    edge->T_a_b = T_a_b;
    // Omega = L L^T  =>  S = L^T gives |S e|^2 = e^T Omega e.
    edge->sqrt_information = llt.matrixL().transpose();
    edge->cost.reset(RelativePoseError::create(T_a_b, edge->sqrt_information));
    Node& na = *it_a->second;
    Node& nb = *it_b->second;
    edge->block = problem_->AddResidualBlock(edge->cost.get(), loss_.get(), na.q, na.t, nb.q, nb.t);
    const EdgeId id = next_edge_id_++;
    na.edges.insert(id);
    nb.edges.insert(id);
    edges_.emplace(id, std::move(edge));
    return id;
}

bool PoseGraph::remove_edge(EdgeId id) {
    auto it = edges_.find(id);
    if (it == edges_.end()) return false;
    problem_->RemoveResidualBlock(it->second->block);
    nodes_.at(it->second->a)->edges.erase(id);
    nodes_.at(it->second->b)->edges.erase(id);
    edges_.erase(it);
    return true;
}

PoseGraphSummary PoseGraph::optimize(int num_threads) {
    PoseGraphSummary summary;
    summary.num_nodes = nodes_.size();
    summary.num_edges = edges_.size();
    if (edges_.empty()) {
        // Nothing constrains anything: the poses stay as they are.
        summary.usable = true;
        summary.converged = true;
        summary.message = "no edges: nothing to optimise";
        return summary;
    }
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    options.max_num_iterations = params_.max_iterations;
    options.function_tolerance = params_.function_tolerance;
    options.gradient_tolerance = params_.gradient_tolerance;
    options.parameter_tolerance = params_.parameter_tolerance;
    options.num_threads = std::max(1, num_threads);
    options.logging_type = ceres::SILENT;
    options.minimizer_progress_to_stdout = false;
    ceres::Solver::Summary ceres_summary;
    ceres::Solve(options, problem_.get(), &ceres_summary);
    summary.usable = ceres_summary.IsSolutionUsable();
    summary.converged = ceres_summary.termination_type == ceres::CONVERGENCE;
    summary.iterations = static_cast<int>(ceres_summary.iterations.size());
    summary.initial_cost = ceres_summary.initial_cost;
    summary.final_cost = ceres_summary.final_cost;
    summary.message = ceres_summary.BriefReport();
    return summary;
}

std::optional<EdgeResidual> PoseGraph::edge_residual(EdgeId id) const {
    auto it = edges_.find(id);
    if (it == edges_.end()) return std::nullopt;
    const Edge& edge = *it->second;
    const Node& na = *nodes_.at(edge.a);
    const Node& nb = *nodes_.at(edge.b);
    const RelativePoseError error(edge.T_a_b, edge.sqrt_information);
    Eigen::Matrix<double, 6, 1> r;
    error(na.q, na.t, nb.q, nb.t, r.data());
    EdgeResidual out;
    out.chi2 = r.squaredNorm();
    const double delta = params_.huber_delta;
    out.robust_weight =
        (delta > 0.0 && out.chi2 > delta * delta) ? delta / std::sqrt(out.chi2) : 1.0;
    const Eigen::Isometry3d E = edge.T_a_b.inverse() * na.get().inverse() * nb.get();
    out.translation_m = E.translation().norm();
    out.rotation_deg = rotation_angle_deg(E.linear(), Eigen::Matrix3d::Identity());
    return out;
}

}  // namespace lidarfuse::core

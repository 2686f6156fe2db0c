#include "core/pipeline/sliding_window.hpp"

namespace lidarfuse::core {

void SlidingWindow::add(std::size_t sensor, std::int64_t frame,
                        const Eigen::Isometry3d& T_root_sensor) {
    const auto id = node_id(sensor, frame);
    graph_->add_node(id, T_root_sensor);
    nodes_.insert(id);
}

void SlidingWindow::remove_sensor(std::size_t sensor) {
    remove_nodes_if([sensor](PoseGraph::NodeId id) { return node_sensor(id) == sensor; });
}

void SlidingWindow::settle_reference(PoseGraph::NodeId reference, std::int64_t free_since,
                                     std::int64_t frame) {
    if (frame - free_since + 1 >= window_frames_) graph_->set_node_fixed(reference, true);
}

void SlidingWindow::slide(std::int64_t frame) {
    const std::int64_t oldest_kept = frame - window_frames_ + 1;
    remove_nodes_if([oldest_kept](PoseGraph::NodeId id) { return node_frame(id) < oldest_kept; });
}

}  // namespace lidarfuse::core

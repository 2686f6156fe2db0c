#include "core/pipeline/sliding_window.hpp"

namespace lidarfuse::core {

void SlidingWindow::add(std::size_t sensor, std::int64_t frame,
                        const Eigen::Isometry3d& T_root_sensor) {
    const auto id = node_id(sensor, frame);
    graph_->add_node(id, T_root_sensor);
    nodes_.insert(id);
}

void SlidingWindow::remove_sensor(std::size_t sensor) {
    for (auto it = nodes_.begin(); it != nodes_.end();) {
        if (node_sensor(*it) == sensor) {
            graph_->remove_node(*it);
            it = nodes_.erase(it);
        } else {
            ++it;
        }
    }
}

void SlidingWindow::settle_reference(PoseGraph::NodeId reference, std::int64_t free_since,
                                     std::int64_t frame) {
    if (frame - free_since + 1 >= window_frames_) graph_->set_node_fixed(reference, true);
}

void SlidingWindow::slide(std::int64_t frame) {
    for (auto it = nodes_.begin(); it != nodes_.end();) {
        if (node_frame(*it) <= frame - window_frames_) {
            graph_->remove_node(*it);
            it = nodes_.erase(it);
        } else {
            ++it;
        }
    }
}

}  // namespace lidarfuse::core

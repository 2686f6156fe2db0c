#pragma once
// The sliding window of the continuous registration (PAPER.md, "Continuous registration"):
// every tracked sensor's pose at each of the last `window_frames` frames is a node of the
// pose graph; a node leaves, with its edges, once its frame is older than the window. A
// sensor's reference node (the frame of its initial registration) is not a window node: it
// stays in the graph as the sensor's anchor, refined while its frame (or the frame it was
// re-anchored, with deskew) is inside the window and held fixed after.
// Not thread safe, like the PoseGraph it edits.

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <set>

#include "core/graph/pose_graph.hpp"

namespace lidarfuse::core {

// Graph node of `sensor` at `frame` (at most 64 sensors).
inline PoseGraph::NodeId node_id(std::size_t sensor, std::int64_t frame) {
    return frame * 64 + static_cast<std::int64_t>(sensor);
}
inline std::size_t node_sensor(PoseGraph::NodeId id) { return static_cast<std::size_t>(id % 64); }
inline std::int64_t node_frame(PoseGraph::NodeId id) { return id / 64; }

class SlidingWindow {
public:
    SlidingWindow(PoseGraph* graph, int window_frames)
        : graph_(graph), window_frames_(window_frames) {}

    // Adds the node of `sensor` at `frame`, at T_root_sensor (its prediction).
    void add(std::size_t sensor, std::int64_t frame, const Eigen::Isometry3d& T_root_sensor);
    // Removes the window nodes (and their edges) of `sensor`; its reference node stays.
    void remove_sensor(std::size_t sensor);
    // Holds a reference node fixed once `frame` is a whole window past `free_since` (the
    // reference frame, or the frame it was last re-anchored).
    void settle_reference(PoseGraph::NodeId reference, std::int64_t free_since, std::int64_t frame);
    // Removes every window node older than the window ending at `frame`.
    void slide(std::int64_t frame);

private:
    // Removes the window nodes for which leaves(id) holds, with their edges.
    template <typename Leaves>
    void remove_nodes_if(Leaves leaves) {
        for (auto it = nodes_.begin(); it != nodes_.end();) {
            if (leaves(*it)) {
                graph_->remove_node(*it);
                it = nodes_.erase(it);
            } else {
                ++it;
            }
        }
    }

    PoseGraph* graph_;
    int window_frames_;
    std::set<PoseGraph::NodeId> nodes_;  // window nodes in the graph (no reference nodes)
};

}  // namespace lidarfuse::core

#include "core/pipeline/sliding_window.hpp"

#include <gtest/gtest.h>

namespace lidarfuse::core {
namespace {

Eigen::Isometry3d at_x(double x) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = x;
    return T;
}

TEST(SlidingWindow, NodeIdsNameTheirSensorAndFrame) {
    for (std::size_t sensor : {0u, 7u, 63u}) {
        for (std::int64_t frame : {0, 1, 12345}) {
            const auto id = node_id(sensor, frame);
            EXPECT_EQ(node_sensor(id), sensor);
            EXPECT_EQ(node_frame(id), frame);
        }
    }
}

TEST(SlidingWindow, KeepsTheLastWindowOfFramesAndTheirEdgesOnly) {
    PoseGraph graph;
    SlidingWindow window(&graph, 3);
    Matrix6d information = Matrix6d::Identity();
    for (std::int64_t f = 0; f < 6; ++f) {
        for (std::size_t s = 0; s < 2; ++s) window.add(s, f, at_x(static_cast<double>(f)));
        if (f > 0) {
            ASSERT_GE(graph.add_edge(node_id(0, f - 1), node_id(0, f), at_x(1.0), information), 0);
        }
        window.slide(f);
        for (std::int64_t g = 0; g <= f; ++g) {
            EXPECT_EQ(graph.has_node(node_id(0, g)), g > f - 3)
                << "frame " << f << ", node of frame " << g;
            EXPECT_EQ(graph.has_node(node_id(1, g)), g > f - 3);
        }
    }
    EXPECT_EQ(graph.num_nodes(), 6u);
    EXPECT_EQ(graph.num_edges(), 2u);  // 3-4 and 4-5: the others left with their nodes
}

TEST(SlidingWindow, RemovingASensorKeepsItsReferenceAndTheOtherSensors) {
    PoseGraph graph;
    SlidingWindow window(&graph, 5);
    graph.add_node(node_id(1, 0), at_x(0.0), true);  // sensor 1's reference: not a window node
    for (std::int64_t f = 1; f < 4; ++f) {
        window.add(0, f, at_x(0.0));
        window.add(1, f, at_x(0.0));
    }
    window.remove_sensor(1);
    EXPECT_TRUE(graph.has_node(node_id(1, 0)));
    for (std::int64_t f = 1; f < 4; ++f) {
        EXPECT_FALSE(graph.has_node(node_id(1, f)));
        EXPECT_TRUE(graph.has_node(node_id(0, f)));
    }
    // Removed for good: sliding past them later removes nothing twice.
    window.slide(100);
    EXPECT_EQ(graph.num_nodes(), 1u);
}

// A reference node pulled 1 m by an edge from a fixed node: free, it moves there; once a
// whole window past its frame, it is held where it is.
TEST(SlidingWindow, AReferenceIsRefinedWhileItsFrameIsInTheWindowAndFixedAfter) {
    PoseGraph graph;
    SlidingWindow window(&graph, 4);
    const auto anchor = node_id(0, 10), reference = node_id(1, 10);
    graph.add_node(anchor, at_x(0.0), true);
    graph.add_node(reference, at_x(0.0));
    ASSERT_GE(graph.add_edge(anchor, reference, at_x(1.0), Matrix6d::Identity()), 0);

    window.settle_reference(reference, 10, 12);  // 3 frames of a window of 4: still free
    ASSERT_TRUE(graph.optimize().usable);
    EXPECT_NEAR(graph.node_pose(reference)->translation().x(), 1.0, 1e-6);

    graph.set_node_pose(reference, at_x(0.5));
    window.settle_reference(reference, 10, 13);  // a whole window: fixed
    graph.optimize();
    EXPECT_NEAR(graph.node_pose(reference)->translation().x(), 0.5, 1e-12);
}

}  // namespace
}  // namespace lidarfuse::core

#pragma once
// Small SVG charts for `lidarfuse eval --plot`: a line chart (one polyline per series, axes
// with ticks, a legend) for error over time, and a top view of a fused cloud. Not a
// plotting library.

#include <cstdint>
#include <string>
#include <vector>

namespace lidarfuse::tools {

struct PlotSeries {
    std::string label;
    std::vector<double> x;
    std::vector<double> y;
};

struct PlotSpec {
    std::string title;
    std::string x_label;
    std::string y_label;
    std::vector<PlotSeries> series;
};

std::string render_svg_line_plot(const PlotSpec& spec);

// A top view (x right, y up) of a point cloud, rasterised to square cells of cell_size_m:
// each cell takes the colour of the sensor with the most points in it, or dark grey when
// most of its points are flagged dynamic. Runs of equal cells in a row become one <rect>,
// which keeps a 200k-point frame at a few hundred kB. The extent is the 1st-99th
// percentile of x and y (stray far points do not shrink the street to a dot), grown to at
// most max_cells cells per side by coarsening the cells.
struct TopViewSpec {
    std::string title;
    std::vector<float> x, y;            // metres
    std::vector<std::uint8_t> sensor;   // per point, index into sensor_labels
    std::vector<std::uint8_t> dynamic;  // per point, 1 = dynamic (may be empty)
    std::vector<std::string> sensor_labels;
    double cell_size_m = 0.2;
    int max_cells = 800;
};

std::string render_svg_top_view(const TopViewSpec& spec);

}  // namespace lidarfuse::tools

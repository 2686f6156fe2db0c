#pragma once
// A small SVG line chart for `lidarfuse eval --plot`: one polyline per series, axes with
// ticks, a legend. Enough to see error over time; not a plotting library.

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

}  // namespace lidarfuse::tools

#include "tools/svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace lidarfuse::tools {

namespace {

constexpr double kWidth = 900, kHeight = 420;
constexpr double kLeft = 80, kRight = 170, kTop = 40, kBottom = 60;
const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                          "#9467bd", "#8c564b", "#e377c2", "#17becf"};

std::string escape(const std::string& text) {
    std::string out;
    for (char c : text) {
        if (c == '<') out += "&lt;";
        else if (c == '>') out += "&gt;";
        else if (c == '&') out += "&amp;";
        else out += c;
    }
    return out;
}

std::string number(double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof(buffer), "%.4g", v);
    return buffer;
}

}  // namespace

std::string render_svg_line_plot(const PlotSpec& spec) {
    double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y1 = 0;
    for (const auto& s : spec.series) {
        for (double v : s.x) x0 = std::min(x0, v), x1 = std::max(x1, v);
        for (double v : s.y) y1 = std::max(y1, v);
    }
    if (!std::isfinite(x0)) x0 = 0, x1 = 1;
    if (x1 <= x0) x1 = x0 + 1;
    if (y1 <= 0) y1 = 1;
    y1 *= 1.05;
    const double pw = kWidth - kLeft - kRight, ph = kHeight - kTop - kBottom;
    const auto px = [&](double x) { return kLeft + (x - x0) / (x1 - x0) * pw; };
    const auto py = [&](double y) { return kTop + ph - y / y1 * ph; };

    std::ostringstream svg;
    svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << kWidth << "\" height=\""
        << kHeight << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
        << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
        << "<text x=\"" << kWidth / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">"
        << escape(spec.title) << "</text>\n";
    for (int i = 0; i <= 5; ++i) {
        const double y = y1 * i / 5, x = x0 + (x1 - x0) * i / 5;
        svg << "<line x1=\"" << kLeft << "\" x2=\"" << kLeft + pw << "\" y1=\"" << py(y)
            << "\" y2=\"" << py(y) << "\" stroke=\"#ddd\"/>\n"
            << "<text x=\"" << kLeft - 6 << "\" y=\"" << py(y) + 4 << "\" text-anchor=\"end\">"
            << number(y) << "</text>\n"
            << "<text x=\"" << px(x) << "\" y=\"" << kTop + ph + 18 << "\" text-anchor=\"middle\">"
            << number(x) << "</text>\n";
    }
    svg << "<rect x=\"" << kLeft << "\" y=\"" << kTop << "\" width=\"" << pw << "\" height=\"" << ph
        << "\" fill=\"none\" stroke=\"black\"/>\n"
        << "<text x=\"" << kLeft + pw / 2 << "\" y=\"" << kHeight - 15
        << "\" text-anchor=\"middle\">" << escape(spec.x_label) << "</text>\n"
        << "<text transform=\"translate(20," << kTop + ph / 2
        << ") rotate(-90)\" text-anchor=\"middle\">" << escape(spec.y_label) << "</text>\n";
    for (std::size_t s = 0; s < spec.series.size(); ++s) {
        const auto& series = spec.series[s];
        const char* colour = kColours[s % (sizeof(kColours) / sizeof(kColours[0]))];
        svg << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"1.5\" points=\"";
        for (std::size_t i = 0; i < std::min(series.x.size(), series.y.size()); ++i) {
            svg << number(px(series.x[i])) << ',' << number(py(series.y[i])) << ' ';
        }
        svg << "\"/>\n";
        const double ly = kTop + 10 + 18.0 * static_cast<double>(s);
        svg << "<line x1=\"" << kLeft + pw + 12 << "\" x2=\"" << kLeft + pw + 36 << "\" y1=\"" << ly
            << "\" y2=\"" << ly << "\" stroke=\"" << colour << "\" stroke-width=\"2\"/>\n"
            << "<text x=\"" << kLeft + pw + 42 << "\" y=\"" << ly + 4 << "\">"
            << escape(series.label) << "</text>\n";
    }
    svg << "</svg>\n";
    return svg.str();
}

}  // namespace lidarfuse::tools

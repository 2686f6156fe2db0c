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
const char* const kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                "#9467bd", "#8c564b", "#e377c2", "#17becf"};

std::string escape(const std::string& text) {
    std::string out;
    for (char c : text) {
        if (c == '<')
            out += "&lt;";
        else if (c == '>')
            out += "&gt;";
        else if (c == '&')
            out += "&amp;";
        else
            out += c;
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

namespace {

// Per cell: point count per sensor (up to 8 shown apart; more share colours) + dynamic.
constexpr int kSlots = 9;  // 8 sensor colours + dynamic
constexpr int kDynamicSlot = 8;
constexpr std::size_t kNumColours = sizeof(kColours) / sizeof(kColours[0]);

// The q-quantile of v (0 for none), by value: v is reordered.
float percentile(std::vector<float> v, double q) {
    if (v.empty()) return 0.0f;
    const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

// The top view's grid: origin (x0_m, y0_m), square cells of cell_m, w x h cells, and per
// cell kSlots point counts.
struct TopViewGrid {
    double x0_m = 0, y0_m = 0, cell_m = 0;
    int w = 1, h = 1;
    std::vector<std::uint32_t> counts;

    std::size_t base(int cx, int cy) const {
        return (static_cast<std::size_t>(cy) * static_cast<std::size_t>(w) +
                static_cast<std::size_t>(cx)) *
               kSlots;
    }
};

// The grid covers the 1st to 99th percentile of the first n points in x and y (outliers
// left out), with cells no smaller than the spec's and at most max_cells along a side.
TopViewGrid top_view_extent(const TopViewSpec& spec, std::size_t n) {
    std::vector<float> xs(spec.x.begin(), spec.x.begin() + static_cast<std::ptrdiff_t>(n));
    std::vector<float> ys(spec.y.begin(), spec.y.begin() + static_cast<std::ptrdiff_t>(n));
    double x0 = percentile(xs, 0.01), x1 = percentile(xs, 0.99);
    double y0 = percentile(ys, 0.01), y1 = percentile(ys, 0.99);
    if (!(x1 > x0)) x1 = x0 + 1;
    if (!(y1 > y0)) y1 = y0 + 1;
    const int max_cells = std::max(10, spec.max_cells);
    TopViewGrid grid;
    grid.x0_m = x0;
    grid.y0_m = y0;
    grid.cell_m = std::max({spec.cell_size_m, (x1 - x0) / max_cells, (y1 - y0) / max_cells});
    grid.w = std::max(1, static_cast<int>(std::ceil((x1 - x0) / grid.cell_m)));
    grid.h = std::max(1, static_cast<int>(std::ceil((y1 - y0) / grid.cell_m)));
    return grid;
}

void count_points(const TopViewSpec& spec, std::size_t n, bool have_dynamic, TopViewGrid* grid) {
    grid->counts.assign(
        static_cast<std::size_t>(grid->w) * static_cast<std::size_t>(grid->h) * kSlots, 0);
    for (std::size_t i = 0; i < n; ++i) {
        const int cx = static_cast<int>(std::floor((spec.x[i] - grid->x0_m) / grid->cell_m));
        const int cy = static_cast<int>(std::floor((spec.y[i] - grid->y0_m) / grid->cell_m));
        if (cx < 0 || cy < 0 || cx >= grid->w || cy >= grid->h) continue;
        ++grid->counts[grid->base(cx, cy) + (have_dynamic && spec.dynamic[i]
                                                 ? kDynamicSlot
                                                 : spec.sensor[i] % kNumColours)];
    }
}

// The slot with the most points in the cell at base; -1: an empty cell. Ties: the lower slot.
int dominant_slot(const TopViewGrid& grid, std::size_t base) {
    int best = -1;
    std::uint32_t best_count = 0;
    for (int k = 0; k < kSlots; ++k) {
        if (grid.counts[base + static_cast<std::size_t>(k)] > best_count) {
            best_count = grid.counts[base + static_cast<std::size_t>(k)];
            best = k;
        }
    }
    return best;
}

// Placement of the drawing in pixels: scale px per cell, the plot's left and top corner.
struct TopViewLayout {
    double scale = 1, left = 20, top = 40, legend = 160, pw = 0, ph = 0;
};

// One rect per run of cells of the same colour along a row (y up: row 0 at the bottom).
void write_cells(const TopViewGrid& grid, const TopViewLayout& l, std::ostringstream* svg) {
    for (int cy = 0; cy < grid.h; ++cy) {
        int run_colour = -1, run_start = 0;
        for (int cx = 0; cx <= grid.w; ++cx) {
            const int c = cx < grid.w ? dominant_slot(grid, grid.base(cx, cy)) : -2;
            if (c == run_colour) continue;
            if (run_colour >= 0) {
                *svg << "<rect x=\"" << number(l.left + run_start * l.scale) << "\" y=\""
                     << number(l.top + l.ph - (cy + 1) * l.scale) << "\" width=\""
                     << number((cx - run_start) * l.scale) << "\" height=\"" << number(l.scale)
                     << "\" fill=\""
                     << (run_colour == kDynamicSlot ? "#444444" : kColours[run_colour]) << "\"/>\n";
            }
            run_colour = c;
            run_start = cx;
        }
    }
}

void write_legend(const TopViewSpec& spec, bool have_dynamic, const TopViewLayout& l,
                  std::ostringstream* svg) {
    std::vector<std::pair<std::string, std::string>> entries;
    for (std::size_t s = 0; s < spec.sensor_labels.size() && s < kNumColours; ++s) {
        entries.emplace_back(kColours[s], spec.sensor_labels[s]);
    }
    if (have_dynamic) entries.emplace_back("#444444", "dynamic");
    for (std::size_t k = 0; k < entries.size(); ++k) {
        const double ly = l.top + 10 + 18.0 * static_cast<double>(k);
        *svg << "<rect x=\"" << number(l.left + l.pw + 12) << "\" y=\"" << number(ly - 6)
             << "\" width=\"12\" height=\"12\" fill=\"" << entries[k].first << "\"/>\n"
             << "<text x=\"" << number(l.left + l.pw + 30) << "\" y=\"" << number(ly + 4) << "\">"
             << escape(entries[k].second) << "</text>\n";
    }
}

}  // namespace

std::string render_svg_top_view(const TopViewSpec& spec) {
    const std::size_t n = std::min({spec.x.size(), spec.y.size(), spec.sensor.size()});
    const bool have_dynamic = spec.dynamic.size() >= n;
    TopViewGrid grid = top_view_extent(spec, n);
    count_points(spec, n, have_dynamic, &grid);
    TopViewLayout l;
    l.scale = 800.0 / std::max(grid.w, grid.h);  // pixels per cell: the longer side 800 px
    l.pw = grid.w * l.scale;
    l.ph = grid.h * l.scale;
    std::ostringstream svg;
    svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << number(l.left + l.pw + l.legend)
        << "\" height=\"" << number(l.top + l.ph + 40)
        << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
        << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
        << "<text x=\"" << number((l.left + l.pw) / 2)
        << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" << escape(spec.title)
        << "</text>\n"
        << "<g shape-rendering=\"crispEdges\">\n";
    write_cells(grid, l, &svg);
    svg << "</g>\n<rect x=\"" << l.left << "\" y=\"" << l.top << "\" width=\"" << number(l.pw)
        << "\" height=\"" << number(l.ph) << "\" fill=\"none\" stroke=\"black\"/>\n"
        << "<text x=\"" << l.left << "\" y=\"" << number(l.top + l.ph + 18) << "\">x "
        << number(grid.x0_m) << " .. " << number(grid.x0_m + grid.w * grid.cell_m) << " m, y "
        << number(grid.y0_m) << " .. " << number(grid.y0_m + grid.h * grid.cell_m) << " m, cell "
        << number(grid.cell_m) << " m</text>\n";
    write_legend(spec, have_dynamic, l, &svg);
    svg << "</svg>\n";
    return svg.str();
}

}  // namespace lidarfuse::tools

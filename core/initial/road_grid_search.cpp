#include "core/initial/road_grid_search.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <unsupported/Eigen/FFT>

#include "core/common/angles.hpp"

namespace lidarfuse::core {

namespace {

using Complex = std::complex<double>;

// What one cloud saw, cell by cell: occupied and free (0 or 1) on an n x n grid around its
// road frame's origin (row: x, column: y), its points turned by `yaw_rad` about z first.
struct RoadGrid {
    int n = 0;
    double cell_m = 1.0;
    double half_m = 0.0;
    std::vector<std::uint8_t> occupied, free;

    // The cell of a horizontal position; false outside the grid.
    bool cell_of(double x, double y, int* row, int* col) const {
        const double r = std::floor((x + half_m) / cell_m), c = std::floor((y + half_m) / cell_m);
        if (!(r >= 0 && c >= 0 && r < n && c < n)) return false;
        *row = static_cast<int>(r);
        *col = static_cast<int>(c);
        return true;
    }
    std::size_t index(int row, int col) const {
        return static_cast<std::size_t>(row) * static_cast<std::size_t>(n) +
               static_cast<std::size_t>(col);
    }
};

RoadGrid make_grid(const std::vector<Eigen::Vector3d>& points, double yaw_rad, double cell_m,
                   const RoadGridSearchParams& p) {
    RoadGrid g;
    g.cell_m = cell_m;
    g.n = static_cast<int>(std::ceil(2.0 * p.half_extent_m / cell_m));
    g.half_m = 0.5 * g.n * cell_m;
    g.occupied.assign(static_cast<std::size_t>(g.n) * static_cast<std::size_t>(g.n), 0);
    std::vector<std::uint8_t> road(g.occupied.size(), 0);
    const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
    int row = 0, col = 0;
    for (const auto& q : points) {
        if (!g.cell_of(c * q.x() - s * q.y(), s * q.x() + c * q.y(), &row, &col)) continue;
        if (q.z() >= p.min_height_m && q.z() <= p.max_height_m) {
            g.occupied[g.index(row, col)] = 1;
        } else if (std::abs(q.z()) <= p.road_tolerance_m) {
            road[g.index(row, col)] = 1;
        }
    }
    g.free.resize(road.size());
    for (std::size_t i = 0; i < road.size(); ++i) g.free[i] = road[i] && !g.occupied[i];
    return g;
}

// The 2-D DFT of an N x N matrix in place: every column, transposed, every column again,
// transposed back.
void fft2(Eigen::FFT<double>* fft, Eigen::MatrixXcd* m, bool inverse) {
    Eigen::VectorXcd column(m->rows()), out(m->rows());
    for (int pass = 0; pass < 2; ++pass) {
        for (Eigen::Index c = 0; c < m->cols(); ++c) {
            column = m->col(c);
            if (inverse) {
                fft->inv(out, column);
            } else {
                fft->fwd(out, column);
            }
            m->col(c) = out;
        }
        m->transposeInPlace();
    }
}

// The spectrum of a + i b for two real grids, zero-padded to N x N (N = 2n: every shift of
// one against the other, none wrapping round).
Eigen::MatrixXcd packed_spectrum(Eigen::FFT<double>* fft, const RoadGrid& g,
                                 const std::vector<float>& a, const std::vector<float>& b) {
    const int N = 2 * g.n;
    Eigen::MatrixXcd z = Eigen::MatrixXcd::Zero(N, N);
    for (int r = 0; r < g.n; ++r) {
        for (int c = 0; c < g.n; ++c) z(r, c) = Complex(a[g.index(r, c)], b[g.index(r, c)]);
    }
    fft2(fft, &z, false);
    return z;
}

// The spectra A, B of the two real grids packed in z (packed_spectrum): A[k] = (z[k] +
// conj(z[-k])) / 2, B[k] = (z[k] - conj(z[-k])) / 2i.
void split_spectra(const Eigen::MatrixXcd& z, Eigen::MatrixXcd* a, Eigen::MatrixXcd* b) {
    const Eigen::Index N = z.rows();
    a->resize(N, N);
    b->resize(N, N);
    for (Eigen::Index c = 0; c < N; ++c) {
        for (Eigen::Index r = 0; r < N; ++r) {
            const Complex zk = z(r, c), zm = std::conj(z((N - r) % N, (N - c) % N));
            (*a)(r, c) = 0.5 * (zk + zm);
            (*b)(r, c) = Complex(0.0, -0.5) * (zk - zm);
        }
    }
}

std::vector<float> as_float(const std::vector<std::uint8_t>& v) {
    return std::vector<float>(v.begin(), v.end());
}

struct GridPeak {
    double score = 0.0;
    double yaw_deg = 0.0;
    Eigen::Vector2d shift_m = Eigen::Vector2d::Zero();
};

// The target's spectra, made once for every yaw.
struct TargetSpectra {
    Eigen::MatrixXcd occupied, free;
};

// The best peaks of one yaw's scores (every shift), each at least `radius` cells from the
// ones before it.
void add_peaks(const Eigen::MatrixXd& score, double yaw_deg, double cell_m, int radius,
               std::vector<GridPeak>* peaks) {
    const Eigen::Index N = score.rows();
    Eigen::MatrixXd s = score;
    for (int k = 0; k < 3; ++k) {
        Eigen::Index r = 0, c = 0;
        const double best = s.maxCoeff(&r, &c);
        if (!(best > 0.0)) return;
        const auto signed_shift = [N](Eigen::Index i) { return i < N / 2 ? i : i - N; };
        peaks->push_back({best, yaw_deg,
                          cell_m * Eigen::Vector2d(static_cast<double>(signed_shift(r)),
                                                   static_cast<double>(signed_shift(c)))});
        for (int dr = -radius; dr <= radius; ++dr) {
            for (int dc = -radius; dc <= radius; ++dc) {
                s((r + dr + N) % N, (c + dc + N) % N) = -1e30;
            }
        }
    }
}

// Score of every shift at one yaw: sum over the source's cells x landing on target cell x
// + shift of occ0 (occ1 - w free1) - w free0 occ1, as one correlation.
Eigen::MatrixXd yaw_scores(Eigen::FFT<double>* fft, const TargetSpectra& target,
                           const std::vector<Eigen::Vector3d>& source, double yaw_deg,
                           const RoadGridSearchParams& p) {
    const RoadGrid g = make_grid(source, yaw_deg * kPi / 180.0, p.coarse_cell_m, p);
    std::vector<float> weighted(g.occupied.size());
    for (std::size_t i = 0; i < weighted.size(); ++i)
        weighted[i] = static_cast<float>(g.occupied[i] - p.free_weight * g.free[i]);
    Eigen::MatrixXcd weighted_spectrum, occupied_spectrum;
    split_spectra(packed_spectrum(fft, g, weighted, as_float(g.occupied)), &weighted_spectrum,
                  &occupied_spectrum);
    Eigen::MatrixXcd cross =
        target.occupied.cwiseProduct(weighted_spectrum.conjugate()) -
        p.free_weight * target.free.cwiseProduct(occupied_spectrum.conjugate());
    fft2(fft, &cross, true);
    return cross.real();
}

// Every coarse yaw step's peaks, on `num_threads` threads, in a fixed order.
std::vector<GridPeak> coarse_peaks(const std::vector<Eigen::Vector3d>& target,
                                   const std::vector<Eigen::Vector3d>& source,
                                   const RoadGridSearchParams& p, int num_threads) {
    const RoadGrid g = make_grid(target, 0.0, p.coarse_cell_m, p);
    TargetSpectra spectra;
    {
        Eigen::FFT<double> fft;
        split_spectra(packed_spectrum(&fft, g, as_float(g.occupied), as_float(g.free)),
                      &spectra.occupied, &spectra.free);
    }
    const int steps = std::max(1, static_cast<int>(std::lround(360.0 / p.coarse_yaw_step_deg)));
    const int radius = static_cast<int>(std::ceil(p.rival_separation_m / p.coarse_cell_m));
    std::vector<std::vector<GridPeak>> per_step(static_cast<std::size_t>(steps));
#pragma omp parallel num_threads(std::max(1, num_threads))
    {
        Eigen::FFT<double> fft;
#pragma omp for schedule(dynamic)
        for (int k = 0; k < steps; ++k) {
            const double yaw = k * 360.0 / steps;
            add_peaks(yaw_scores(&fft, spectra, source, yaw, p), yaw, p.coarse_cell_m, radius,
                      &per_step[static_cast<std::size_t>(k)]);
        }
    }
    std::vector<GridPeak> peaks;
    for (const auto& step : per_step) peaks.insert(peaks.end(), step.begin(), step.end());
    return peaks;
}

double yaw_difference_deg(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

// The source's occupied and free cell centres (its own road frame) on the fine grid.
void fine_centres(const RoadGrid& g, std::vector<Eigen::Vector2d>* occupied,
                  std::vector<Eigen::Vector2d>* free) {
    for (int r = 0; r < g.n; ++r) {
        for (int c = 0; c < g.n; ++c) {
            const Eigen::Vector2d centre((r + 0.5) * g.cell_m - g.half_m,
                                         (c + 0.5) * g.cell_m - g.half_m);
            if (g.occupied[g.index(r, c)]) occupied->push_back(centre);
            if (g.free[g.index(r, c)]) free->push_back(centre);
        }
    }
}

// The coarse peak refined on the fine grid: every fine yaw within one coarse step and
// every fine shift within one coarse cell and a half, scored directly on the cells.
GridPeak refine(const std::vector<Eigen::Vector3d>& target,
                const std::vector<Eigen::Vector3d>& source, const GridPeak& coarse,
                const RoadGridSearchParams& p) {
    const RoadGrid t = make_grid(target, 0.0, p.fine_cell_m, p);
    std::vector<Eigen::Vector2d> occupied, free;
    fine_centres(make_grid(source, 0.0, p.fine_cell_m, p), &occupied, &free);
    const int reach = static_cast<int>(std::ceil(1.5 * p.coarse_cell_m / p.fine_cell_m));
    const int yaw_steps = static_cast<int>(std::ceil(p.coarse_yaw_step_deg / p.fine_yaw_step_deg));
    const int side = 2 * reach + 1;
    GridPeak best = coarse;
    best.score = -1e30;
    std::vector<double> score(static_cast<std::size_t>(side * side));
    for (int k = -yaw_steps; k <= yaw_steps; ++k) {
        const double yaw = coarse.yaw_deg + k * p.fine_yaw_step_deg;
        const Eigen::Rotation2Dd R(yaw * kPi / 180.0);
        std::fill(score.begin(), score.end(), 0.0);
        const auto add = [&](const std::vector<Eigen::Vector2d>& cells, bool is_occupied) {
            for (const auto& centre : cells) {
                const Eigen::Vector2d q = R * centre + coarse.shift_m;
                int r0 = 0, c0 = 0;
                if (!t.cell_of(q.x(), q.y(), &r0, &c0)) continue;
                for (int dr = -reach; dr <= reach; ++dr) {
                    for (int dc = -reach; dc <= reach; ++dc) {
                        const int r = r0 + dr, c = c0 + dc;
                        if (r < 0 || c < 0 || r >= t.n || c >= t.n) continue;
                        const std::size_t i = t.index(r, c);
                        const double v = is_occupied ? t.occupied[i] - p.free_weight * t.free[i]
                                                     : -p.free_weight * t.occupied[i];
                        score[static_cast<std::size_t>((dr + reach) * side + dc + reach)] += v;
                    }
                }
            }
        };
        add(occupied, true);
        add(free, false);
        const auto it = std::max_element(score.begin(), score.end());
        if (*it <= best.score) continue;
        const int i = static_cast<int>(it - score.begin());
        best.score = *it;
        best.yaw_deg = yaw;
        best.shift_m =
            coarse.shift_m + p.fine_cell_m * Eigen::Vector2d(i / side - reach, i % side - reach);
    }
    return best;
}

std::string figures(const char* format, double a, double b, double c, double d) {
    char text[200];
    std::snprintf(text, sizeof(text), format, a, b, c, d);
    return text;
}

}  // namespace

RoadGridPlacement search_road_grid(const std::vector<Eigen::Vector3d>& target,
                                   const std::vector<Eigen::Vector3d>& source,
                                   const RoadGridSearchParams& params, int num_threads) {
    RoadGridPlacement out;
    std::vector<GridPeak> peaks = coarse_peaks(target, source, params, num_threads);
    const auto by_score = [](const GridPeak& a, const GridPeak& b) {
        if (a.score != b.score) return a.score > b.score;
        if (a.yaw_deg != b.yaw_deg) return a.yaw_deg < b.yaw_deg;
        return a.shift_m.x() != b.shift_m.x() ? a.shift_m.x() < b.shift_m.x()
                                              : a.shift_m.y() < b.shift_m.y();
    };
    std::sort(peaks.begin(), peaks.end(), by_score);
    if (peaks.empty() || peaks.front().score < params.min_score_cells) {
        out.why =
            figures("too little in common: the best placement scores %.0f cells (at least %.0f)",
                    peaks.empty() ? 0.0 : peaks.front().score, params.min_score_cells, 0, 0);
        return out;
    }
    const GridPeak& best = peaks.front();
    out.score = best.score;
    for (const GridPeak& p : peaks) {
        if ((p.shift_m - best.shift_m).norm() < params.rival_separation_m &&
            yaw_difference_deg(p.yaw_deg, best.yaw_deg) < params.rival_separation_deg) {
            continue;
        }
        out.rival_score = p.score;
        out.rival_yaw_deg = p.yaw_deg;
        out.rival_shift_m = p.shift_m;
        break;
    }
    if (out.rival_score > params.max_rival_share * best.score) {
        out.why = figures(
            "ambiguous: a placement %.0f m / %.0f deg from the best scores %.0f of its %.0f cells",
            (out.rival_shift_m - best.shift_m).norm(),
            yaw_difference_deg(out.rival_yaw_deg, best.yaw_deg), out.rival_score, best.score);
        return out;
    }
    const GridPeak fine = refine(target, source, best, params);
    out.found = true;
    out.yaw_deg = fine.yaw_deg;
    out.T_target_source = Eigen::Isometry3d::Identity();
    out.T_target_source.linear() =
        Eigen::AngleAxisd(fine.yaw_deg * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    out.T_target_source.translation() = Eigen::Vector3d(fine.shift_m.x(), fine.shift_m.y(), 0.0);
    return out;
}

}  // namespace lidarfuse::core

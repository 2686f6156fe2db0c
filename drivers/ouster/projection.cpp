#include "drivers/ouster/projection.hpp"

namespace lidarfuse::ouster {

namespace {

template <typename Point>
bool project_points(const LidarScan& scan, const XyzLut& lut, const ProjectionParams& params,
                    ScanCloud* out, std::vector<Point>* points) {
    using Scalar = typename Point::Scalar;
    points->clear();
    out->num_points = 0;
    out->pixel_index.clear();
    out->frame_id = scan.frame_id;
    out->rows = scan.rows();
    out->columns = scan.columns();
    out->column_timestamp_ns.assign(scan.timestamp_ns.begin(), scan.timestamp_ns.end());

    const std::vector<std::uint32_t>& range = params.second_return ? scan.range2_mm : scan.range_mm;
    const std::size_t w = scan.columns();
    const std::size_t n = scan.rows() * w;
    if (range.size() != n || static_cast<std::size_t>(lut.width) != w ||
        static_cast<std::size_t>(lut.height) != scan.rows() ||
        static_cast<std::size_t>(lut.direction.rows()) != n ||
        static_cast<std::size_t>(lut.offset.rows()) != n) {
        return false;
    }
    points->reserve(n);
    if (params.keep_pixel_index) out->pixel_index.reserve(n);

    const double* dir = lut.direction.data();  // row-major (H*W) x 3
    const double* off = lut.offset.data();
    const std::uint32_t min_range = params.min_range_mm > 0 ? params.min_range_mm : 1;
    for (std::size_t row = 0; row < scan.rows(); ++row) {
        const std::size_t base = row * w;
        for (std::size_t col = 0; col < w; ++col) {
            const std::size_t i = base + col;
            const std::uint32_t r_mm = range[i];
            if (r_mm < min_range || !scan.received[col]) continue;
            const double r_m = r_mm * 1e-3;
            const double* d = dir + 3 * i;
            const double* o = off + 3 * i;
            points->emplace_back(static_cast<Scalar>(o[0] + r_m * d[0]),
                                 static_cast<Scalar>(o[1] + r_m * d[1]),
                                 static_cast<Scalar>(o[2] + r_m * d[2]));
            if (params.keep_pixel_index) out->pixel_index.push_back(static_cast<std::uint32_t>(i));
        }
    }
    out->num_points = points->size();
    return true;
}

}  // namespace

bool project_scan(const LidarScan& scan, const XyzLut& lut, const ProjectionParams& params,
                  ScanCloud* out) {
    out->cloud.clear();
    return project_points(scan, lut, params, out, &out->cloud.points);
}

bool project_scan(const LidarScan& scan, const XyzLut& lut, const ProjectionParams& params,
                  ScanCloud* out, std::vector<Eigen::Vector3f>* points) {
    out->cloud.clear();
    return project_points(scan, lut, params, out, points);
}

std::uint64_t scan_reference_time_ns(const LidarScan& scan) {
    for (std::size_t c = 0; c < scan.columns(); ++c) {
        if (scan.received[c]) return scan.timestamp_ns[c];
    }
    return 0;
}

void point_times_s(const ScanCloud& cloud, std::uint64_t reference_ns, std::vector<float>* out) {
    out->assign(cloud.num_points, 0.0f);
    if (cloud.pixel_index.size() != cloud.num_points || cloud.columns == 0) return;
    // Differences of unsigned sensor timestamps, taken without a signed overflow: a
    // corrupted or jumping column timestamp may lie anywhere in 0..2^64 - 1.
    for (std::size_t i = 0; i < out->size(); ++i) {
        const std::uint64_t t = cloud.timestamp_ns_of(i);
        const double dt_ns = t >= reference_ns ? static_cast<double>(t - reference_ns)
                                               : -static_cast<double>(reference_ns - t);
        (*out)[i] = static_cast<float>(dt_ns * 1e-9);
    }
}

void point_intensity(const LidarScan& scan, const ScanCloud& cloud, std::vector<float>* out) {
    out->assign(cloud.num_points, 0.0f);
    if (cloud.pixel_index.size() != cloud.num_points) return;
    const std::size_t pixels = cloud.rows * cloud.columns;
    const auto fill = [&](const auto& field) {
        if (field.size() != pixels) return false;
        for (std::size_t i = 0; i < out->size(); ++i) {
            const std::uint32_t px = cloud.pixel_index[i];
            if (px < pixels) (*out)[i] = static_cast<float>(field[px]);
        }
        return true;
    };
    if (!fill(scan.signal)) fill(scan.reflectivity);
}

}  // namespace lidarfuse::ouster

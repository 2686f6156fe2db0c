// Semantic metadata checks: counts against pixels_per_column, ranges, transforms.

#include "drivers/ouster/metadata_checks.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <sstream>

#include "drivers/ouster/packet_format.hpp"

namespace lidarfuse::ouster::detail {
namespace {

class Checker {
public:
    Checker(const std::set<std::string>& bad, std::vector<std::string>* problems)
        : bad_(bad), problems_(problems) {}
    bool usable(const std::string& path) const { return bad_.count(path) == 0; }
    void problem(const std::string& path, const std::string& message) {
        problems_->push_back(path + ": " + message);
    }

    void count(const std::string& path, std::size_t got, int expected, const char* what) {
        if (usable(path) && got != static_cast<std::size_t>(expected)) {
            problem(path, "expected " + std::to_string(expected) + " " + what + ", got " +
                              std::to_string(got));
        }
    }

    void angles(const std::string& path, const std::vector<double>& values, double limit) {
        if (!usable(path)) return;
        for (std::size_t i = 0; i < values.size(); ++i) {
            if (!(std::fabs(values[i]) <= limit)) {
                std::ostringstream msg;
                msg << "angle " << values[i] << " deg outside [-" << limit << ", " << limit << "]";
                problem(path + "[" + std::to_string(i) + "]", msg.str());
            }
        }
    }

    // Homogeneous rigid transform: last row (0 0 0 1), rotation orthonormal with det +1.
    void rigid(const std::string& path, const Eigen::Matrix4d& m) {
        if (!usable(path)) return;
        if (!m.allFinite()) {
            problem(path, "contains a non-finite value");
            return;
        }
        if (!m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 1e-9) ||
            std::fabs(m(3, 3) - 1.0) > 1e-9) {
            problem(path, "last row must be [0, 0, 0, 1]");
        }
        const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
        const double orth_error =
            (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
        if (orth_error > 1e-3 || r.determinant() < 0.0) {
            std::ostringstream msg;
            msg << "rotation part is not a proper rotation (|R^T R - I| = " << orth_error
                << ", det = " << r.determinant() << ")";
            problem(path, msg.str());
        }
    }

private:
    const std::set<std::string>& bad_;
    std::vector<std::string>* problems_;
};

// Fields of the document's own members (not of the nested sections): the parser reports
// these against the document's own keys.
void check_member_fields(const SensorInfo& info, const MetadataPaths& paths, Checker& c) {
    const int w = info.columns_per_frame;
    if (!info.lidar_mode.empty()) {
        const auto mode = parse_lidar_mode(info.lidar_mode);
        if (!mode) {
            c.problem("lidar_mode", "unknown mode \"" + info.lidar_mode + "\"");
        } else if ((*mode)[0] != w || (*mode)[1] != info.frames_per_second) {
            c.problem("columns_per_frame",
                      std::to_string(w) + " x " + std::to_string(info.frames_per_second) +
                          " Hz contradicts lidar_mode \"" + info.lidar_mode + "\"");
        }
    }
    if (info.init_id > 0xFFFFFFu) c.problem("init_id", "exceeds 24 bits");
    if (info.frames_per_second <= 0) c.problem("frames_per_second", "must be positive");
    if (info.azimuth_window_mdeg[0] < 0 || info.azimuth_window_mdeg[0] > 360000 ||
        info.azimuth_window_mdeg[1] < 0 || info.azimuth_window_mdeg[1] > 360000) {
        c.problem(paths.azimuth_window(), "values must be in 0..360000 millidegrees");
    }
}

// The scan's shape, which the later checks count against: h_ok, w_ok.
struct ShapeOk {
    bool h_ok = false;  // pixels_per_column usable and a beam count Ouster makes
    bool w_ok = false;  // columns_per_frame usable and in 1..65535
};

ShapeOk check_shape(const SensorInfo& info, const MetadataPaths& paths, Checker& c) {
    const int h = info.pixels_per_column;
    const int w = info.columns_per_frame;
    ShapeOk ok;
    ok.h_ok = c.usable(paths.pixels_per_column()) && (h == 16 || h == 32 || h == 64 || h == 128);
    if (c.usable(paths.pixels_per_column()) && !ok.h_ok) {
        c.problem(paths.pixels_per_column(),
                  "expected 16, 32, 64 or 128 (one row per beam), got " + std::to_string(h));
    }
    ok.w_ok = c.usable(paths.columns_per_frame()) && w > 0 && w <= 65535;
    if (!ok.w_ok && c.usable(paths.columns_per_frame())) {
        c.problem(paths.columns_per_frame(), "must be in 1..65535, got " + std::to_string(w));
    }
    return ok;
}

// One entry per beam, angles in range (deg), pixel shifts smaller than the frame's width.
void check_beam_tables(const SensorInfo& info, const MetadataPaths& paths, ShapeOk ok, Checker& c) {
    const int h = info.pixels_per_column;
    const int w = info.columns_per_frame;
    if (ok.h_ok) {
        c.count(paths.altitude(), info.beam_altitude_angles_deg.size(), h, "numbers");
        c.count(paths.azimuth(), info.beam_azimuth_angles_deg.size(), h, "numbers");
        c.count(paths.pixel_shift(), info.pixel_shift_by_row.size(), h, "integers");
    }
    c.angles(paths.altitude(), info.beam_altitude_angles_deg, 90.0);
    c.angles(paths.azimuth(), info.beam_azimuth_angles_deg, 180.0);
    if (ok.w_ok && c.usable(paths.pixel_shift())) {
        for (std::size_t i = 0; i < info.pixel_shift_by_row.size(); ++i) {
            if (std::abs(info.pixel_shift_by_row[i]) >= w) {
                c.problem(paths.pixel_shift() + "[" + std::to_string(i) + "]",
                          "shift " + std::to_string(info.pixel_shift_by_row[i]) +
                              " is not smaller than columns_per_frame " + std::to_string(w));
            }
        }
    }
}

// In range, dividing the frame's width, and a packet layout the UDP profile has.
void check_columns_per_packet(const SensorInfo& info, const MetadataPaths& paths, ShapeOk ok,
                              Checker& c) {
    const int h = info.pixels_per_column;
    const int w = info.columns_per_frame;
    const int cpp = info.columns_per_packet;
    if (!c.usable(paths.columns_per_packet())) return;
    if (cpp < 1 || cpp > 256) {
        c.problem(paths.columns_per_packet(), "must be in 1..256, got " + std::to_string(cpp));
    } else if (ok.w_ok && w % cpp != 0) {
        c.problem(paths.columns_per_packet(),
                  std::to_string(cpp) + " does not divide columns_per_frame " + std::to_string(w));
    } else if (ok.h_ok) {
        try {
            const PacketFormat format(info.udp_profile_lidar, h, cpp);
            (void)format;
        } catch (const std::invalid_argument& e) {
            c.problem(paths.columns_per_packet(), e.what());
        }
    }
}

void check_column_window(const SensorInfo& info, const MetadataPaths& paths, ShapeOk ok,
                         Checker& c) {
    const int w = info.columns_per_frame;
    if (!ok.w_ok || !c.usable(paths.column_window())) return;
    for (int k = 0; k < 2; ++k) {
        const int v = info.column_window[static_cast<std::size_t>(k)];
        if (v < 0 || v >= w) {
            c.problem(paths.column_window() + "[" + std::to_string(k) + "]",
                      std::to_string(v) + " outside 0.." + std::to_string(w - 1));
        }
    }
}

// The beam origin offset (mm) and the three rigid transforms.
void check_geometry(const SensorInfo& info, const MetadataPaths& paths, Checker& c) {
    if (c.usable(paths.beam_origin()) && !(info.lidar_origin_to_beam_origin_mm >= 0.0 &&
                                           info.lidar_origin_to_beam_origin_mm < 1000.0)) {
        std::ostringstream msg;
        msg << "expected 0..1000 mm, got " << info.lidar_origin_to_beam_origin_mm;
        c.problem(paths.beam_origin(), msg.str());
    }
    c.rigid(paths.beam_to_lidar(), info.beam_to_lidar_transform);
    c.rigid(paths.lidar_to_sensor, info.lidar_to_sensor_transform);
    c.rigid(paths.imu_to_sensor, info.imu_to_sensor_transform);
}

}  // namespace

MetadataPaths member_paths() {
    MetadataPaths p;
    p.lidar_to_sensor = "lidar_to_sensor_transform";
    p.imu_to_sensor = "imu_to_sensor_transform";
    p.members = true;
    return p;
}

// Problems are reported in this order; tests and users read them in it.
void check_semantics(const SensorInfo& info, const MetadataPaths& paths,
                     const std::set<std::string>& bad, std::vector<std::string>* problems) {
    Checker c(bad, problems);
    if (paths.members) check_member_fields(info, paths, c);
    const ShapeOk ok = check_shape(info, paths, c);
    check_beam_tables(info, paths, ok, c);
    check_columns_per_packet(info, paths, ok, c);
    check_column_window(info, paths, ok, c);
    check_geometry(info, paths, c);
}

}  // namespace lidarfuse::ouster::detail

#include "drivers/sim/sensor_model.hpp"

#include <algorithm>
#include <cmath>

#include "drivers/sim/rng.hpp"

namespace lidarfuse::sim {

ColumnRenderer::ColumnRenderer(const ouster::SensorInfo& info, const SensorModelParams& params)
    : params_(params), lut_(ouster::make_xyz_lut(info)) {
    const Eigen::Matrix4d& b2l = info.beam_to_lidar_transform;
    beam_offset_m_ = std::hypot(b2l(0, 3), b2l(2, 3)) * 1e-3;
    range_quantum_mm_ =
        info.udp_profile_lidar == ouster::UdpProfileLidar::kRng15Rfl8Nir8 ||
                info.udp_profile_lidar == ouster::UdpProfileLidar::kFusaRng15Rfl8Nir8Dual
            ? 8u
            : 1u;
}

int ColumnRenderer::render(const StaticScene& scene, const DynamicScene* dynamic, float time01,
                           const Eigen::Isometry3d& T_world_sensor, int m, std::uint64_t key,
                           PixelReturn* out) const {
    const Eigen::Matrix3d R = T_world_sensor.linear();
    const Eigen::Vector3d t = T_world_sensor.translation();
    int returns = 0;
    for (int row = 0; row < lut_.height; ++row) {
        const Eigen::Index i = static_cast<Eigen::Index>(row) * lut_.width + m;
        const Eigen::Vector3d dir_s = lut_.direction.row(i).transpose();
        const Eigen::Vector3d origin = R * lut_.offset.row(i).transpose() + t;
        const Eigen::Vector3d dir = R * dir_s;
        CounterRng rng(key, static_cast<std::uint64_t>(m) * 256u + static_cast<std::uint64_t>(row));
        PixelReturn px;
        px.near_ir =
            static_cast<std::uint16_t>(600 + 400 * std::max(0.0, dir.z()) + 40 * rng.uniform());

        double t_near = beam_offset_m_;
        RayHit hit;
        for (int pass = 0; pass <= params_.max_transmissions; ++pass) {
            hit = scene.cast(origin, dir, t_near, params_.max_range_m, dynamic, time01);
            if (!hit.hit) break;
            const MaterialProps& mat = material_props(hit.material);
            if (mat.transmission <= 0 || rng.uniform() >= mat.transmission) break;
            t_near = hit.distance_m + 1e-3;  // passed through a gap in the crown
            hit.hit = false;
        }
        if (hit.hit && hit.distance_m >= params_.min_range_m) {
            const MaterialProps& mat = material_props(hit.material);
            const double cos_inc = std::clamp(-hit.normal.dot(dir), 0.0, 1.0);
            const double r = hit.distance_m;
            const double albedo = mat.retro ? 8.0 * mat.reflectivity : mat.reflectivity;
            const double facing = mat.retro ? std::max(cos_inc, 0.5) : cos_inc;
            const double signal = params_.signal_gain * albedo * facing / (r * r);
            const double x =
                (signal / params_.detection_signal) * (signal / params_.detection_signal);
            const double p_detect = x > 40.0 ? 1.0 : 1.0 - std::exp(-x);
            const double u_detect = rng.uniform();
            if (!params_.dropouts || u_detect < p_detect) {
                const double noise =
                    params_.noise_sigma_m > 0 ? params_.noise_sigma_m * rng.normal() : 0.0;
                const double range_mm = std::max(0.0, (r + noise) * 1000.0);
                const auto q = static_cast<double>(range_quantum_mm_);
                px.range_mm =
                    static_cast<std::uint32_t>(std::llround(range_mm / q)) * range_quantum_mm_;
                // Shot noise on the signal, a few percent on reflectivity and ambient light:
                // uniform jitter is enough for these fields (only range needs a Gaussian).
                px.signal = static_cast<std::uint16_t>(
                    std::clamp(signal * rng.uniform(0.92, 1.08), 1.0, 65535.0));
                const double refl = mat.retro ? 200.0 + 50.0 * mat.reflectivity
                                              : 100.0 * mat.reflectivity * rng.uniform(0.95, 1.05);
                px.reflectivity = static_cast<std::uint8_t>(std::clamp(refl, 1.0, 255.0));
                px.near_ir = static_cast<std::uint16_t>(std::clamp(
                    200.0 + 1500.0 * mat.reflectivity + rng.uniform(-50.0, 50.0), 0.0, 4080.0));
                if (px.range_mm > 0) ++returns;
            }
        }
        out[row] = px;
    }
    return returns;
}

}  // namespace lidarfuse::sim

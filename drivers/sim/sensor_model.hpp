#pragma once
// What one OS1-64 column measures: one ray per beam from the beam's origin along its
// direction, both taken from the project's own xyz lookup table (drivers/ouster/xyz_lut),
// so that decoding a simulated packet with the ingest reproduces the hit point exactly
// (up to range noise and quantisation):
//   p_sensor = offset + range * direction   (xyz_lut.hpp)
// The beam leaves at offset + n * direction (n = beam origin offset), so the simulated
// range of a hit at distance t from `offset` is t itself.
//
// Return model (per pixel, seeded by (seed, sensor, frame, column, row) so that the result
// does not depend on threads):
//   - tree crowns pass a ray on with their material's transmission probability;
//   - received signal S = k * albedo * cos(incidence) / r^2 (retro-reflectors: strong and
//     nearly independent of incidence); the return is detected with probability
//     1 - exp(-(S / S0)^2), so returns fade with range and grazing incidence;
//   - range noise N(0, sigma), then quantised as the profile stores it (1 mm; RNG15: 8 mm);
//   - no return (sky, dropout, out of [min, max] range): range 0, near-IR = ambient.

#include <Eigen/Geometry>
#include <cstdint>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/xyz_lut.hpp"
#include "drivers/sim/ray_caster.hpp"

namespace lidarfuse::sim {

struct SensorModelParams {
    double noise_sigma_m = 0.1 / 3.0;  // 3 sigma = 10 cm (PAPER.md)
    double min_range_m = 0.3;
    double max_range_m = 120.0;
    double signal_gain = 1.1e6;     // photons * m^2 at albedo 1, normal incidence
    double detection_signal = 8.0;  // S0: 63 % detection probability
    bool dropouts = true;           // false: every hit in range is returned
    int max_transmissions = 6;      // crown surfaces a ray may pass before it stops
};

struct PixelReturn {
    std::uint32_t range_mm = 0;
    std::uint16_t signal = 0;
    std::uint8_t reflectivity = 0;
    std::uint16_t near_ir = 0;
};

class ColumnRenderer {
public:
    ColumnRenderer(const ouster::SensorInfo& info, const SensorModelParams& params);

    int rows() const { return lut_.height; }
    int columns() const { return lut_.width; }
    const ouster::XyzLut& lut() const { return lut_; }

    // Renders column `measurement_id` from pose T_world_sensor; `time01` places the
    // column in the dynamic scene's window. `key` identifies (seed, sensor, frame).
    // Writes rows() entries into `out`. Returns the number of pixels with a return.
    int render(const StaticScene& scene, const DynamicScene* dynamic, float time01,
               const Eigen::Isometry3d& T_world_sensor, int measurement_id, std::uint64_t key,
               PixelReturn* out) const;

private:
    SensorModelParams params_;
    ouster::XyzLut lut_;
    double beam_offset_m_;  // n: the ray starts this far along the direction
    std::uint32_t range_quantum_mm_;
};

}  // namespace lidarfuse::sim

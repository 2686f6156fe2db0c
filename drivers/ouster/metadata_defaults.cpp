// Profile names, lidar modes and Ouster's documented defaults for absent metadata keys.

#include <cctype>
#include <cmath>

#include "drivers/ouster/metadata.hpp"

namespace lidarfuse::ouster {
namespace {

struct ProfileName {
    UdpProfileLidar profile;
    const char* name;
};
constexpr ProfileName kLidarProfileNames[] = {
    {UdpProfileLidar::kLegacy, "LEGACY"},
    {UdpProfileLidar::kRng19Rfl8Sig16Nir16, "RNG19_RFL8_SIG16_NIR16"},
    {UdpProfileLidar::kRng15Rfl8Nir8, "RNG15_RFL8_NIR8"},
    {UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual, "RNG19_RFL8_SIG16_NIR16_DUAL"},
    {UdpProfileLidar::kFusaRng15Rfl8Nir8Dual, "FUSA_RNG15_RFL8_NIR8_DUAL"},
};

}  // namespace

const char* to_string(UdpProfileLidar profile) {
    for (const ProfileName& p : kLidarProfileNames) {
        if (p.profile == profile) return p.name;
    }
    return "UNKNOWN";
}

const char* to_string(UdpProfileImu /*profile*/) { return "LEGACY"; }

std::optional<UdpProfileLidar> udp_profile_lidar_from_string(std::string_view name) {
    for (const ProfileName& p : kLidarProfileNames) {
        if (name == p.name) return p.profile;
    }
    return std::nullopt;
}

std::optional<UdpProfileImu> udp_profile_imu_from_string(std::string_view name) {
    if (name == "LEGACY") return UdpProfileImu::kLegacy;
    return std::nullopt;
}

std::optional<std::array<int, 2>> parse_lidar_mode(std::string_view mode) {
    constexpr std::array<int, 2> kModes[] = {{512, 10},  {512, 20},  {1024, 10},
                                             {1024, 20}, {2048, 10}, {4096, 5}};
    for (const auto& m : kModes) {
        if (mode == std::to_string(m[0]) + "x" + std::to_string(m[1])) return m;
    }
    return std::nullopt;
}

std::uint64_t SensorInfo::serial_number() const {
    if (prod_sn.empty() || prod_sn.size() > 19) return 0;
    std::uint64_t value = 0;
    for (const char c : prod_sn) {
        if (!std::isdigit(static_cast<unsigned char>(c))) return 0;
        value = value * 10 + static_cast<std::uint64_t>(c - '0');
    }
    return value;
}

Eigen::Matrix4d default_lidar_to_sensor_transform() {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m(0, 0) = -1.0;
    m(1, 1) = -1.0;
    m(2, 3) = kDefaultLidarToSensorZMm;
    return m;
}

Eigen::Matrix4d default_imu_to_sensor_transform() {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m(0, 3) = 6.253;
    m(1, 3) = -11.775;
    m(2, 3) = 7.645;
    return m;
}

double default_lidar_origin_to_beam_origin_mm(const std::string& prod_line) {
    if (prod_line.rfind("OS-0-", 0) == 0) return 27.67;
    if (prod_line.rfind("OS-1-", 0) == 0) return 15.806;
    if (prod_line.rfind("OS-2-", 0) == 0) return 13.762;
    return kDefaultLidarOriginToBeamOriginMm;  // gen-1 OS-1 and unknown product lines
}

std::vector<int> pixel_shift_from_azimuths(const std::vector<double>& beam_azimuth_angles_deg,
                                           int columns_per_frame) {
    std::vector<int> shift;
    shift.reserve(beam_azimuth_angles_deg.size());
    for (const double az : beam_azimuth_angles_deg) {
        shift.push_back(static_cast<int>(std::lround(az * columns_per_frame / 360.0)));
    }
    return shift;
}

std::vector<int> default_pixel_shift_by_row(const std::vector<double>& beam_azimuth_angles_deg,
                                            int pixels_per_column, int columns_per_frame) {
    const bool gen1_mode = columns_per_frame == 512 || columns_per_frame == 1024 ||
                           columns_per_frame == 2048 || columns_per_frame == 4096;
    if (pixels_per_column == 64 && gen1_mode) {
        const int step = 3 * columns_per_frame / 512;
        std::vector<int> shift(64);
        for (int row = 0; row < 64; ++row)
            shift[static_cast<std::size_t>(row)] = (3 - row % 4) * step;
        return shift;
    }
    if (pixels_per_column > 0 &&
        beam_azimuth_angles_deg.size() == static_cast<std::size_t>(pixels_per_column)) {
        return pixel_shift_from_azimuths(beam_azimuth_angles_deg, columns_per_frame);
    }
    return std::vector<int>(static_cast<std::size_t>(std::max(pixels_per_column, 0)), 0);
}

}  // namespace lidarfuse::ouster

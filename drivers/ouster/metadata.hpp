#pragma once
// Ouster sensor metadata ("sensor_info" JSON): parsed into SensorInfo with Ouster's
// documented defaults for keys that older firmware omits, validated as a whole.
//
// Two document forms are accepted:
//  - nested (FW >= 2.4 / SDK >= 0.9): `sensor_info`, `beam_intrinsics`, `lidar_intrinsics`,
//    `imu_intrinsics`, `lidar_data_format`, `config_params`, `calibration_status`, ...
//  - legacy flat (FW <= 2.3 and the SDK's own old output): beam angles, prod_sn, lidar_mode,
//    transforms at the top level plus a `data_format` object; the reduced form that only
//    holds the two beam angle arrays and lidar_mode is accepted too.
// Defaults (applied only when a key is absent; each one is listed in `defaults_applied`):
//  - lidar_origin_to_beam_origin_mm by prod_line: "OS-0-" 27.67, "OS-1-" 15.806, "OS-2-"
//    13.762, otherwise (gen-1 OS-1, or no prod_line) 12.163
//  - beam_to_lidar_transform: identity with x translation = lidar_origin_to_beam_origin_mm
//  - lidar_to_sensor_transform: diag(-1, -1, 1), z translation 36.18 mm
//  - imu_to_sensor_transform: identity with translation (6.253, -11.775, 7.645) mm
//  - columns_per_packet 16, pixels_per_column = number of beam altitude angles,
//    column_window [0, W-1], udp_profile_lidar / udp_profile_imu LEGACY, ports 7502 / 7503,
//    azimuth window [0, 360000] mdeg, fps from lidar_mode
//  - pixel_shift_by_row: for 64 rows the SDK's gen-1 table for the mode, the pattern
//    {3s, 2s, s, 0} repeated with s = 3 W / 512 (1024 columns: 18, 12, 6, 0); for other
//    row counts derived from the beams: round(azimuth_deg * W / 360).
//
// Errors: parsing collects every problem with its JSON path and throws one MetadataError
// listing all of them (e.g. `beam_intrinsics.beam_altitude_angles: expected 64 numbers,
// got 63`). Malformed JSON is a MetadataError naming the file and the parser's position.
// Thread safety: free functions without shared state.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace lidarfuse::ouster {

// UDP lidar packet profiles (config key `udp_profile_lidar`).
enum class UdpProfileLidar : std::uint8_t {
    kLegacy,                   // "LEGACY": per-column headers/footers, 12 B pixels
    kRng19Rfl8Sig16Nir16,      // "RNG19_RFL8_SIG16_NIR16": single return, 12 B pixels
    kRng15Rfl8Nir8,            // "RNG15_RFL8_NIR8": low data rate, 4 B pixels
    kRng19Rfl8Sig16Nir16Dual,  // "RNG19_RFL8_SIG16_NIR16_DUAL": two returns, 16 B pixels
    kFusaRng15Rfl8Nir8Dual,    // "FUSA_RNG15_RFL8_NIR8_DUAL": FuSa header, 8 B pixels
};

// UDP IMU packet profiles (config key `udp_profile_imu`); only LEGACY (48 B) exists.
enum class UdpProfileImu : std::uint8_t { kLegacy };

// Ouster's spelling ("RNG15_RFL8_NIR8"...). Unknown names give nullopt.
const char* to_string(UdpProfileLidar profile);
const char* to_string(UdpProfileImu profile);
std::optional<UdpProfileLidar> udp_profile_lidar_from_string(std::string_view name);
std::optional<UdpProfileImu> udp_profile_imu_from_string(std::string_view name);

// Which document form a SensorInfo came from.
enum class MetadataForm : std::uint8_t { kNested, kLegacyFlat, kBuiltInCode };

struct SensorInfo {
    // Identity.
    std::string prod_sn;    // serial number as printed, e.g. "122239000672" (may be empty)
    std::string prod_line;  // e.g. "OS-1-64-AH" (empty in the reduced legacy form)
    std::string prod_pn;
    std::string build_rev;  // firmware, e.g. "v2.5.2"
    std::string image_rev;
    std::string status;         // "RUNNING", ...
    std::uint32_t init_id = 0;  // initialization_id (24 bits on the wire)

    // Mode and data format.
    std::string lidar_mode = "1024x10";  // "<columns>x<fps>"
    int columns_per_frame = 1024;
    int frames_per_second = 10;
    int pixels_per_column = 64;
    int columns_per_packet = 16;
    UdpProfileLidar udp_profile_lidar = UdpProfileLidar::kLegacy;
    UdpProfileImu udp_profile_imu = UdpProfileImu::kLegacy;
    std::vector<int> pixel_shift_by_row;  // size pixels_per_column, in columns
    // Measurement-id window [first, last] the sensor fills, inclusive; first > last wraps
    // through column 0 (e.g. [370, 85] of 512). lidar_scan.hpp's ColumnWindow mirrors it.
    std::array<int, 2> column_window{0, 1023};

    // Intrinsics. Angles in degrees, one per beam (row), as Ouster stores them.
    std::vector<double> beam_altitude_angles_deg;
    std::vector<double> beam_azimuth_angles_deg;
    double lidar_origin_to_beam_origin_mm = 12.163;  // Ouster's n
    // 4x4 homogeneous transforms with translations in millimetres, as Ouster stores them.
    Eigen::Matrix4d beam_to_lidar_transform = Eigen::Matrix4d::Identity();
    Eigen::Matrix4d lidar_to_sensor_transform = Eigen::Matrix4d::Identity();
    Eigen::Matrix4d imu_to_sensor_transform = Eigen::Matrix4d::Identity();

    // Network and timing configuration.
    std::uint16_t udp_port_lidar = 7502;
    std::uint16_t udp_port_imu = 7503;
    std::string udp_dest;        // destination address configured on the sensor
    std::string timestamp_mode;  // "TIME_FROM_INTERNAL_OSC", "TIME_FROM_PTP_1588", ...
    std::array<int, 2> azimuth_window_mdeg{0, 360000};  // [start, end] millidegrees

    // Provenance.
    MetadataForm form = MetadataForm::kBuiltInCode;
    std::vector<std::string> defaults_applied;  // JSON keys that were absent and defaulted

    // The serial as the 40-bit integer carried in non-legacy packet headers; 0 if prod_sn
    // is empty or not a decimal number.
    std::uint64_t serial_number() const;
};

// Thrown by parse/load/validation with every problem found, each prefixed by its JSON path.
class MetadataError : public std::runtime_error {
public:
    MetadataError(const std::string& source, std::vector<std::string> problems);
    const std::vector<std::string>& problems() const { return problems_; }
    const std::string& source() const { return source_; }

private:
    std::string source_;
    std::vector<std::string> problems_;
};

// Parses and validates a metadata document (either form). `source_name` names it in errors.
SensorInfo parse_metadata(const std::string& json_text, const std::string& source_name);

// Reads and parses a metadata file; errors name the file.
SensorInfo load_metadata(const std::filesystem::path& path);

// Checks a SensorInfo built in code (the simulator) with the same rules as the parser;
// returns every problem, empty when valid. Paths name SensorInfo members.
std::vector<std::string> validate_sensor_info(const SensorInfo& info);

// Writes the nested form (sensor_info, beam_intrinsics, lidar_intrinsics, imu_intrinsics,
// lidar_data_format, config_params, calibration_status) that parse_metadata reads back to
// an equal SensorInfo (up to `form` and `defaults_applied`). Pretty-printed, 2 spaces.
std::string to_nested_json(const SensorInfo& info);

// Columns and frame rate of a lidar_mode string ("2048x10" -> {2048, 10}); nullopt when
// the string is not one of Ouster's modes (512x10, 512x20, 1024x10, 1024x20, 2048x10,
// 4096x5).
std::optional<std::array<int, 2>> parse_lidar_mode(std::string_view mode);

// Ouster's defaults, exposed so the simulator and tests use the same numbers.
constexpr double kDefaultLidarOriginToBeamOriginMm = 12.163;
constexpr double kDefaultLidarToSensorZMm = 36.18;
Eigen::Matrix4d default_lidar_to_sensor_transform();
Eigen::Matrix4d default_imu_to_sensor_transform();
// round(azimuth_deg * columns_per_frame / 360) for every beam.
std::vector<int> pixel_shift_from_azimuths(const std::vector<double>& beam_azimuth_angles_deg,
                                           int columns_per_frame);
// The default applied when pixel_shift_by_row is absent (see the top of this file); zeros
// when neither rule applies (azimuth count differs from the row count).
std::vector<int> default_pixel_shift_by_row(const std::vector<double>& beam_azimuth_angles_deg,
                                            int pixels_per_column, int columns_per_frame);
// n by product line (see the top of this file).
double default_lidar_origin_to_beam_origin_mm(const std::string& prod_line);

}  // namespace lidarfuse::ouster

#pragma once
// The sample table and helpers shared by the Ouster metadata tests (ouster_metadata_test,
// ouster_metadata_problems_test): a header, so that a bundled build compiling both in one
// unit defines them once.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "drivers/ouster/metadata.hpp"

namespace lidarfuse::ouster::metadata_test {

inline bool has_problem(const std::vector<std::string>& problems, const std::string& needle) {
    for (const auto& p : problems) {
        if (p.find(needle) != std::string::npos) return true;
    }
    return false;
}

inline std::string joined(const std::vector<std::string>& problems) {
    std::string s;
    for (const auto& p : problems) s += p + "\n";
    return s;
}

struct Expected {
    const char* file;
    const char* serial;
    MetadataForm form;
    const char* mode;
    int columns;
    UdpProfileLidar profile;
    int rows;
    int port_lidar;
    int port_imu;
    std::array<int, 2> window;
    std::uint32_t init_id;
    double beam_origin_mm;
};

// Every sample file of the test data with what it must parse to.
inline const Expected kSamples[] = {
    {"OS-0-128-U1_v2.3.0_1024x10.json",
     "122150000150",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     7502,
     7503,
     {0, 1023},
     5431292,
     27.67},
    {"OS-0-32-U1_v2.2.0_1024x10.json",
     "992137000142",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
     32,
     7502,
     7503,
     {0, 1023},
     9599938,
     27.67},
    {"OS-1-32-G_v2.1.1_1024x10.json",
     "992101000280",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     32,
     7502,
     7503,
     {0, 1023},
     0,
     15.806},
    {"OS-1-64_sensor_config_reduced.json",
     "",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     64,
     7502,
     7503,
     {0, 1023},
     0,
     12.163},
    {"OS-2-128-U1_v2.3.0_1024x10.json",
     "992210000957",
     MetadataForm::kLegacyFlat,
     "1024x10",
     1024,
     UdpProfileLidar::kRng19Rfl8Sig16Nir16,
     128,
     7502,
     7503,
     {0, 1023},
     5431293,
     13.762},
    {"crc_test.json",
     "122247000785",
     MetadataForm::kNested,
     "512x10",
     512,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     7502,
     7503,
     {0, 511},
     11394290,
     27.116},
    {"duplicate_id.json",
     "992219000042",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     34636,
     48887,
     {0, 1023},
     8247312,
     13.762},
    {"same_ports.1.json",
     "122247000785",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kFusaRng15Rfl8Nir8Dual,
     128,
     7502,
     7502,
     {912, 1022},
     390073,
     27.116},
    {"same_ports.2.json",
     "122239000672",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     64,
     7502,
     7502,
     {912, 1022},
     16413612,
     15.806},
    {"same_ports_legacy.1.json",
     "122247000785",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     128,
     7502,
     7502,
     {0, 1023},
     15278603,
     27.116},
    {"same_ports_legacy.2.json",
     "122239000672",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kLegacy,
     64,
     7502,
     7502,
     {0, 1023},
     9342168,
     15.806},
    {"same_ports_nonlegacy.1.json",
     "122247000785",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kFusaRng15Rfl8Nir8Dual,
     128,
     7502,
     7502,
     {0, 1023},
     390078,
     27.116},
    {"same_ports_nonlegacy.2.json",
     "122239000672",
     MetadataForm::kNested,
     "1024x10",
     1024,
     UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
     64,
     7502,
     7502,
     {0, 1023},
     9342165,
     15.806},
    {"windowed_frame1_0.json",
     "992108000265",
     MetadataForm::kNested,
     "512x10",
     512,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     53750,
     7503,
     {1, 256},
     7109746,
     27.67},
    {"windowed_frame2_0.json",
     "992108000265",
     MetadataForm::kNested,
     "512x10",
     512,
     UdpProfileLidar::kRng15Rfl8Nir8,
     128,
     53750,
     7503,
     {370, 85},
     7109747,
     27.67},
};

}  // namespace lidarfuse::ouster::metadata_test

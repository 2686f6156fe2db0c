// The packet layouts of Ouster's UDP lidar profiles and header types (from Ouster's
// sensor documentation of the lidar data packets), one table row per profile and header.

#include "drivers/ouster/packet_format.hpp"

namespace lidarfuse::ouster {
namespace {

// Field order follows the Field enum: range, range2, signal, signal2, reflectivity,
// reflectivity2, near_ir. {offset, bytes, mask, upshift}; bytes 0 = absent.
constexpr FieldSpec kAbsent{0, 0, 0, 0};
constexpr ProfileLayout kLayouts[] = {
    {UdpProfileLidar::kLegacy,
     HeaderType::kLegacy,
     12,
     1,
     {{0, 4, 0xFFFFF, 0},
      kAbsent,
      {6, 2, 0xFFFF, 0},
      kAbsent,
      {4, 1, 0xFF, 0},
      kAbsent,
      {8, 2, 0xFFFF, 0}}},
    {UdpProfileLidar::kRng19Rfl8Sig16Nir16,
     HeaderType::kStandard,
     12,
     1,
     {{0, 4, 0x7FFFF, 0},
      kAbsent,
      {6, 2, 0xFFFF, 0},
      kAbsent,
      {4, 1, 0xFF, 0},
      kAbsent,
      {8, 2, 0xFFFF, 0}}},
    {UdpProfileLidar::kRng15Rfl8Nir8,
     HeaderType::kStandard,
     4,
     1,
     {{0, 2, 0x7FFF, 3}, kAbsent, kAbsent, kAbsent, {2, 1, 0xFF, 0}, kAbsent, {3, 1, 0xFF, 4}}},
    {UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
     HeaderType::kStandard,
     16,
     2,
     {{0, 4, 0x7FFFF, 0},
      {4, 4, 0x7FFFF, 0},
      {8, 2, 0xFFFF, 0},
      {10, 2, 0xFFFF, 0},
      {3, 1, 0xFF, 0},
      {7, 1, 0xFF, 0},
      {12, 2, 0xFFFF, 0}}},
    {UdpProfileLidar::kFusaRng15Rfl8Nir8Dual,
     HeaderType::kFusa,
     8,
     2,
     {{0, 2, 0x7FFF, 3},
      {4, 2, 0x7FFF, 3},
      kAbsent,
      kAbsent,
      {2, 1, 0xFF, 0},
      {6, 1, 0xFF, 0},
      {3, 1, 0xFF, 4}}},
};

// Field order follows the HeaderField enum. {offset, bytes, mask, in_column_footer}.
constexpr HeaderFieldSpec kNone{0, 0, 0, false};
constexpr HeaderFieldSpec kTimestamp{0, 8, ~0ULL, false};
constexpr HeaderFieldSpec kMeasurementId{8, 2, 0xFFFF, false};
constexpr HeaderLayout kHeaderLayouts[] = {
    {HeaderType::kLegacy,
     0,
     16,
     4,
     0,
     {kNone,
      kNone,
      kNone,
      kNone,
      kNone,
      kNone,
      kNone,
      kNone,
      kNone,
      kTimestamp,
      kMeasurementId,
      {0, 4, 0xFFFFFFFF, true},
      {10, 2, 0xFFFF, false},
      {12, 4, 0xFFFFFFFF, false}}},
    {HeaderType::kStandard,
     32,
     12,
     0,
     32,
     {{0, 2, 0xFFFF, false},
      {2, 2, 0xFFFF, false},
      {4, 3, 0xFFFFFF, false},
      {7, 5, 0xFFFFFFFFFF, false},
      {12, 1, 0xFF, false},
      {16, 1, 0xFF, false},
      {17, 1, 0xFF, false},
      {18, 1, 0x0F, false},
      {19, 1, 0x0F, false},
      kTimestamp,
      kMeasurementId,
      {10, 2, 0xFFFF, false},
      kNone,
      kNone}},
    {HeaderType::kFusa,
     32,
     12,
     0,
     32,
     {{0, 1, 0xFF, false},
      {4, 4, 0xFFFFFFFF, false},
      {1, 3, 0xFFFFFF, false},
      {11, 5, 0xFFFFFFFFFF, false},
      {8, 1, 0xFF, false},
      {16, 1, 0xFF, false},
      {17, 1, 0xFF, false},
      {18, 1, 0x0F, false},
      {19, 1, 0x0F, false},
      kTimestamp,
      kMeasurementId,
      {10, 2, 0xFFFF, false},
      kNone,
      kNone}},
};

}  // namespace

const HeaderLayout& header_layout(HeaderType type) {
    for (const HeaderLayout& l : kHeaderLayouts) {
        if (l.type == type) return l;
    }
    return kHeaderLayouts[0];
}

const ProfileLayout& profile_layout(UdpProfileLidar profile) {
    for (const ProfileLayout& l : kLayouts) {
        if (l.profile == profile) return l;
    }
    return kLayouts[0];
}

}  // namespace lidarfuse::ouster

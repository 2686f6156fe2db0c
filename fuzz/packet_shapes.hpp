#pragma once
// The sensor shapes fuzz_ouster_packets can describe in its 16-byte input header, indexed
// by header bytes. seed_corpus.cpp writes the index of each sample capture's shape, so the
// two must read the same tables: this file is their only copy.

#include "drivers/ouster/metadata.hpp"

namespace lidarfuse::fuzz {

inline constexpr ouster::UdpProfileLidar kPacketProfiles[] = {
    ouster::UdpProfileLidar::kLegacy, ouster::UdpProfileLidar::kRng19Rfl8Sig16Nir16,
    ouster::UdpProfileLidar::kRng15Rfl8Nir8, ouster::UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
    ouster::UdpProfileLidar::kFusaRng15Rfl8Nir8Dual};
inline constexpr int kPacketColumns[] = {512, 1024, 2048};
inline constexpr int kPacketRows[] = {16, 32, 64, 128};
inline constexpr int kPacketColumnsPerPacket[] = {16, 8, 32, 4};

}  // namespace lidarfuse::fuzz

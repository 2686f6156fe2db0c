// ScanAssembler on synthetic packets written with PacketFormat's encoder: every profile's
// fields land at the right pixel, wrap-around, reordering, duplicates, late packets,
// init_id changes, loss, azimuth windows, IMU / wrong size / wrong serial / bad CRC
// packets, no allocation per packet. (The frame bookkeeping alone is tested on bare headers
// in ouster_frame_window_test, the projection of an assembled scan in ouster_projection_test.)
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <random>
#include <vector>

#include "drivers/ouster/packet_format.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "tests/drivers/ouster_packet_rig.hpp"

// Counts heap allocations while `g_count_allocations` is set (zero-allocation test). The
// replacement pairs malloc/free by design; GCC cannot see that through inlining.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
namespace {
std::atomic<bool> g_count_allocations{false};
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
    if (g_count_allocations.load(std::memory_order_relaxed)) ++g_allocations;
    if (void* p = std::malloc(size ? size : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace lidarfuse::ouster {
namespace {

using namespace packet_rig;  // NOLINT(google-build-using-namespace): the tests' vocabulary

class EveryProfile : public ::testing::TestWithParam<UdpProfileLidar> {};

TEST_P(EveryProfile, FullFrameLandsAtTheRightPixelsWithUpshifts) {
    const auto info = make_info(GetParam());
    Rig rig(info);
    rig.send_frame(1234);
    ASSERT_EQ(rig.frames.size(), 1u);
    EXPECT_TRUE(rig.frames[0].complete);
    const LidarScan& s = rig.last;
    const PacketFormat& f = rig.writer.format();
    EXPECT_EQ(s.frame_id, 1234u);
    EXPECT_EQ(s.packets, 8u);
    EXPECT_EQ(s.has(ScanField::kRange2), f.has_field(Field::kRange2));
    EXPECT_EQ(s.has(ScanField::kSignal), f.has_field(Field::kSignal));
    EXPECT_EQ(s.has(ScanField::kNearIr), f.has_field(Field::kNearIr));
    const bool legacy = f.header_type() == HeaderType::kLegacy;
    for (int mid = 0; mid < 64; ++mid) {
        EXPECT_EQ(s.measurement_id[mid], mid);
        EXPECT_EQ(s.timestamp_ns[mid], 1234'000'000'000ull + 1000ull * mid);
        EXPECT_EQ(s.status[mid], legacy ? 0xFFFFFFFFull : 1ull);
        if (!legacy) {
            EXPECT_EQ(s.init_id, kInitId);
        }
        for (int row = 0; row < 16; ++row) {
            const std::size_t i = static_cast<std::size_t>(row) * 64 + mid;
            ASSERT_EQ(s.range_mm[i], range_of(row, mid, 1234)) << row << "," << mid;
            EXPECT_EQ(s.reflectivity[i], refl_of(row, mid));
            if (s.has(ScanField::kRange2)) {
                EXPECT_EQ(s.range2_mm[i], range2_of(row, mid));
            }
            if (s.has(ScanField::kSignal)) {
                EXPECT_EQ(s.signal[i], signal_of(row, mid));
            }
            if (s.has(ScanField::kSignal2)) {
                EXPECT_EQ(s.signal2[i], signal_of(row, mid) + 1);
            }
            if (s.has(ScanField::kReflectivity2)) {
                EXPECT_EQ(s.reflectivity2[i], 255 - refl_of(row, mid));
            }
            if (s.has(ScanField::kNearIr)) {
                EXPECT_EQ(s.near_ir[i], nir_of(row, mid));
            }
        }
    }
}

// A packet is written row by row when its columns are new and in a row, and column by
// column otherwise: partly received packets, a packet that wraps past the frame's last
// column, and swapped measurement ids must land every column at its own id.
TEST_P(EveryProfile, ColumnsOutOfOrderOrAlreadyReceivedLandAtTheirOwnIds) {
    const auto info = make_info(GetParam());
    Rig rig(info);
    const PacketFormat& f = rig.writer.format();
    constexpr std::uint32_t kFrame = 5;
    rig.send(kFrame, 0);
    EXPECT_EQ(rig.send(kFrame, 4), PacketOutcome::kAssembled);  // 4-7 again, 8-11 new
    std::vector<std::uint8_t> swapped = rig.writer.packet(kFrame, 12);
    f.set_column_measurement_id(f.column(swapped.data(), 0), 13);
    f.set_column_measurement_id(f.column(swapped.data(), 1), 12);
    f.write_crc(swapped.data());
    EXPECT_EQ(rig.assembler.add_packet(swapped.data(), swapped.size()), PacketOutcome::kAssembled);
    for (int c = 20; c < 60; c += 8) rig.send(kFrame, c);
    EXPECT_EQ(rig.send(kFrame, 60), PacketOutcome::kAssembled);  // 60-63, then 0-3 again
    ASSERT_EQ(rig.frames.size(), 1u);
    EXPECT_TRUE(rig.frames[0].complete);
    EXPECT_EQ(rig.assembler.counters().duplicate_columns, 8u);
    const LidarScan& s = rig.last;
    for (int mid = 0; mid < 64; ++mid) {
        const int source = mid == 12 ? 13 : mid == 13 ? 12 : mid;  // whose data it holds
        EXPECT_EQ(s.timestamp_ns[mid], 1'000'000'000ull * kFrame + 1000ull * source);
        for (int row = 0; row < 16; ++row) {
            const std::size_t i = static_cast<std::size_t>(row) * 64 + mid;
            ASSERT_EQ(s.range_mm[i], range_of(row, source, kFrame)) << row << "," << mid;
            ASSERT_EQ(s.reflectivity[i], refl_of(row, source)) << row << "," << mid;
            if (s.has(ScanField::kNearIr)) {
                ASSERT_EQ(s.near_ir[i], nir_of(row, source)) << row << "," << mid;
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Profiles, EveryProfile,
                         ::testing::Values(UdpProfileLidar::kLegacy,
                                           UdpProfileLidar::kRng19Rfl8Sig16Nir16,
                                           UdpProfileLidar::kRng15Rfl8Nir8,
                                           UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
                                           UdpProfileLidar::kFusaRng15Rfl8Nir8Dual));

TEST(ScanAssembler, SixteenBitWrapAroundWithoutSpuriousLoss) {
    Rig rig(make_info(UdpProfileLidar::kRng19Rfl8Sig16Nir16));
    for (std::uint32_t f : {65534u, 65535u, 0u, 1u}) rig.send_frame(f);
    ASSERT_EQ(rig.frames.size(), 4u);
    EXPECT_EQ(rig.frames[2].frame_id, 0u);
    const auto& c = rig.assembler.counters();
    EXPECT_EQ(c.frames_complete, 4u);
    EXPECT_EQ(c.late_packets + c.missing_columns + c.resets + c.frames_incomplete, 0u);
}

TEST(ScanAssembler, FusaFrameIdsAreThirtyTwoBits) {
    Rig rig(make_info(UdpProfileLidar::kFusaRng15Rfl8Nir8Dual));
    for (std::uint32_t f : {70000u, 0xFFFFFFFFu, 0u}) rig.send_frame(f);
    ASSERT_EQ(rig.frames.size(), 3u);
    EXPECT_EQ(rig.frames[0].frame_id, 70000u);  // would be 4464 if cut to 16 bits
    EXPECT_EQ(rig.frames[2].frame_id, 0u);
    EXPECT_EQ(rig.assembler.counters().frames_complete, 3u);
    EXPECT_EQ(rig.assembler.counters().late_packets, 0u);
}

TEST(ScanAssembler, ReorderDuplicatesAndLatePackets) {
    Rig rig(make_info(UdpProfileLidar::kRng15Rfl8Nir8));
    for (int c : {8, 0, 24, 16, 32, 40, 48}) rig.send(10, c);
    EXPECT_EQ(rig.send(11, 0), PacketOutcome::kAssembled);  // next frame starts early
    EXPECT_EQ(rig.send(10, 8), PacketOutcome::kDuplicate);
    EXPECT_EQ(rig.send(10, 56), PacketOutcome::kAssembled);  // completes 10
    ASSERT_EQ(rig.frames.size(), 1u);
    EXPECT_TRUE(rig.frames[0].complete);
    EXPECT_EQ(rig.send(10, 56), PacketOutcome::kLate);
    EXPECT_EQ(rig.send(9, 0), PacketOutcome::kLate);
    const auto& c = rig.assembler.counters();
    EXPECT_EQ(c.duplicate_packets, 1u);
    EXPECT_EQ(c.duplicate_columns, 8u);
    EXPECT_EQ(c.late_packets, 2u);
    EXPECT_EQ(c.lidar_packets, 12u);
}

TEST(ScanAssembler, InitIdChangeMidFrameResets) {
    Rig rig(make_info(UdpProfileLidar::kRng19Rfl8Sig16Nir16));
    rig.send(300, 0);
    rig.send(300, 8);
    rig.send(0, 0, kInitId + 1);
    ASSERT_EQ(rig.frames.size(), 1u);
    EXPECT_EQ(rig.frames[0].frame_id, 300u);
    EXPECT_DOUBLE_EQ(rig.frames[0].completeness, 0.25);
    for (int c = 8; c < 64; c += 8) rig.send(0, c, kInitId + 1);
    ASSERT_EQ(rig.frames.size(), 2u);
    EXPECT_TRUE(rig.frames[1].complete);
    EXPECT_EQ(rig.last.init_id, kInitId + 1);
    EXPECT_EQ(rig.assembler.counters().resets, 1u);
}

TEST(ScanAssembler, MissingPacketsLeaveInvalidColumnsAndLowerCompleteness) {
    Rig rig(make_info(UdpProfileLidar::kLegacy));
    for (int c = 0; c < 64; c += 8) {
        if (c != 16 && c != 40) rig.send(5, c);
    }
    rig.send_frame(6);
    ASSERT_EQ(rig.frames.size(), 2u);
    EXPECT_DOUBLE_EQ(rig.frames[0].completeness, 48.0 / 64.0);
    EXPECT_EQ(rig.assembler.counters().missing_columns, 16u);
    rig.send(7, 0);
    rig.assembler.flush();
    ASSERT_EQ(rig.frames.size(), 3u);
    const LidarScan& s = rig.last;  // frame 7: only columns 0..7
    EXPECT_EQ(s.received[7], 1);
    EXPECT_EQ(s.received[8], 0);
    EXPECT_EQ(s.status[8], 0u);
    EXPECT_EQ(s.range_mm[8], 0u);
}

TEST(ScanAssembler, WindowWrappingThroughZeroIsNotLoss) {
    // Like windowed_frame2: window [56, 9] of 64 columns; the sensor sends the packets
    // overlapping it (0..15 and 56..63), with status 0 outside the window.
    Rig rig(make_info(UdpProfileLidar::kRng15Rfl8Nir8, 16, 64, {56, 9}));
    rig.send(20, 0);
    rig.send(20, 8);
    EXPECT_TRUE(rig.frames.empty());
    rig.send(20, 56);
    ASSERT_EQ(rig.frames.size(), 1u);
    EXPECT_TRUE(rig.frames[0].complete);
    EXPECT_EQ(rig.last.expected_columns(), 18u);
    EXPECT_EQ(rig.last.status[10], 0u);  // received, outside the window
    EXPECT_EQ(rig.last.status[9], 1u);
    EXPECT_EQ(rig.assembler.counters().missing_columns, 0u);
    EXPECT_EQ(rig.assembler.counters().frames_incomplete, 0u);
}

TEST(ScanAssembler, ImuWrongSizeWrongSerialAndBadCrcAreSkippedAndCounted) {
    Rig rig(make_info(UdpProfileLidar::kRng19Rfl8Sig16Nir16));
    const std::vector<std::uint8_t> imu(48, 0xAB);
    EXPECT_EQ(rig.assembler.add_packet(imu.data(), imu.size()), PacketOutcome::kImu);
    auto pkt = rig.writer.packet(3, 0);
    EXPECT_EQ(rig.assembler.add_packet(pkt.data(), pkt.size() - 1), PacketOutcome::kWrongSize);
    pkt.push_back(0);
    EXPECT_EQ(rig.assembler.add_packet(pkt.data(), pkt.size()), PacketOutcome::kWrongSize);
    EXPECT_EQ(rig.assembler.add_packet(nullptr, 0), PacketOutcome::kWrongSize);
    EXPECT_EQ(rig.send(3, 0, kInitId, kSerial + 1), PacketOutcome::kWrongProfile);
    auto corrupt = rig.writer.packet(3, 0);
    corrupt[100] ^= 0x01;
    EXPECT_EQ(rig.assembler.add_packet(corrupt.data(), corrupt.size()), PacketOutcome::kCrcError);
    // Firmware that does not fill the CRC: zero, or the FW 2.3 marker. Both are accepted.
    auto unfilled = rig.writer.packet(3, 8);
    const std::size_t crc_at = unfilled.size() - 8;
    std::fill(unfilled.begin() + static_cast<std::ptrdiff_t>(crc_at), unfilled.end(), 0);
    EXPECT_EQ(rig.assembler.add_packet(unfilled.data(), unfilled.size()),
              PacketOutcome::kAssembled);
    auto marker = rig.writer.packet(3, 16);
    constexpr std::uint8_t kMarker[8] = {0xde, 0xc0, 0x00, 0x00, 0xef, 0xbe, 0xad, 0xde};
    std::copy(kMarker, kMarker + 8, marker.begin() + static_cast<std::ptrdiff_t>(crc_at));
    EXPECT_EQ(rig.assembler.add_packet(marker.data(), marker.size()), PacketOutcome::kAssembled);

    const auto& c = rig.assembler.counters();
    EXPECT_EQ(c.packets, 8u);
    EXPECT_EQ(c.imu_packets, 1u);
    EXPECT_EQ(c.bad_size, 3u);
    EXPECT_EQ(c.bad_profile, 1u);
    EXPECT_EQ(c.crc_errors, 1u);
    EXPECT_EQ(c.lidar_packets, 2u);
    EXPECT_TRUE(rig.frames.empty());
    rig.assembler.flush();
    ASSERT_EQ(rig.frames.size(), 1u);
    EXPECT_DOUBLE_EQ(rig.frames[0].completeness, 16.0 / 64.0);  // the dropped ones are missing

    ScanAssemblerParams no_crc;
    no_crc.check_crc = false;
    Rig lenient(make_info(UdpProfileLidar::kRng19Rfl8Sig16Nir16), no_crc);
    EXPECT_EQ(lenient.assembler.add_packet(corrupt.data(), corrupt.size()),
              PacketOutcome::kAssembled);
}

TEST(ScanAssembler, NoAllocationPerPacketInSteadyState) {
    Rig rig(make_info(UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual, 32, 128));
    std::vector<std::vector<std::uint8_t>> packets;
    for (std::uint32_t f = 0; f < 12; ++f) {
        for (int c = 0; c < 128; c += 8) {
            if (f == 7 && c == 64) continue;  // one loss, so the eviction path runs too
            packets.push_back(rig.writer.packet(f, c));
        }
    }
    packets.push_back(packets[3]);  // a late packet
    std::size_t i = 0;
    for (; i < 32; ++i) rig.assembler.add_packet(packets[i].data(), packets[i].size());
    g_allocations = 0;
    g_count_allocations = true;
    for (; i < packets.size(); ++i) rig.assembler.add_packet(packets[i].data(), packets[i].size());
    rig.assembler.flush();
    g_count_allocations = false;
    EXPECT_EQ(g_allocations.load(), 0);
    EXPECT_EQ(rig.assembler.counters().frames_complete, 11u);
    EXPECT_EQ(rig.assembler.counters().frames_incomplete, 1u);
    EXPECT_EQ(rig.assembler.counters().late_packets, 1u);
}

TEST(ScanAssembler, RandomAndBitFlippedPacketsNeverBreakIt) {
    std::mt19937 rng(20261121);
    for (auto profile : {UdpProfileLidar::kLegacy, UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
                         UdpProfileLidar::kFusaRng15Rfl8Nir8Dual}) {
        auto info = make_info(profile);
        info.prod_sn.clear();  // no serial check: random headers reach the frame logic
        ScanAssemblerParams params;
        params.check_crc = false;
        Rig rig(info, params);
        std::uint64_t emitted_packets = 0;
        for (int i = 0; i < 3000; ++i) {
            std::vector<std::uint8_t> p =
                rig.writer.packet(static_cast<std::uint32_t>(i / 8), (i % 8) * 8);
            const int mode = static_cast<int>(rng() % 3);
            if (mode == 0) {
                for (auto& b : p) b = static_cast<std::uint8_t>(rng());
            } else if (mode == 1) {
                for (int k = 0; k < 4; ++k)
                    p[rng() % p.size()] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
            }
            std::size_t size = p.size();
            if (rng() % 10 == 0) size = rng() % (p.size() + 1);
            rig.assembler.add_packet(p.data(), size);
        }
        rig.assembler.flush();
        const auto& c = rig.assembler.counters();
        EXPECT_EQ(c.packets, 3000u);
        EXPECT_EQ(c.packets,
                  c.lidar_packets + c.imu_packets + c.bad_size + c.bad_profile + c.crc_errors);
        for (const auto& f : rig.frames) {
            EXPECT_GE(f.completeness, 0.0);
            EXPECT_LE(f.completeness, 1.0);
        }
        EXPECT_EQ(rig.frames.size(), c.frames_complete + c.frames_incomplete);
        emitted_packets += c.lidar_packets;
        EXPECT_GT(emitted_packets, 0u);
    }
}

TEST(ScanAssembler, RejectsAColumnWindowOutsideTheFrame) {
    EXPECT_THROW(ScanAssembler(make_info(UdpProfileLidar::kLegacy, 16, 64, {0, 64}), {}, nullptr),
                 std::invalid_argument);
}

}  // namespace
}  // namespace lidarfuse::ouster

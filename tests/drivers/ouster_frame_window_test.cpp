// Frame bookkeeping of the scan assembler on synthetic packet headers: wrap-around,
// reordering, duplicates, late packets, resets, loss and azimuth windows.
#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <vector>

#include "drivers/ouster/frame_window.hpp"

namespace lidarfuse::ouster {
namespace {

struct Emitted {
    std::uint32_t frame_id;
    bool complete;
    double completeness;
    std::uint32_t packets;
    std::vector<std::uint8_t> received;
    std::vector<std::uint64_t> timestamp_ns;
};

// Drives a FrameWindow the way the assembler does, with packets of `cols_per_packet`
// consecutive columns; each written column gets timestamp = 1000 * frame + column.
class Harness {
public:
    explicit Harness(std::size_t columns, std::size_t cols_per_packet,
                     FrameWindowParams params = {},
                     std::optional<ColumnWindow> window = std::nullopt)
        : cols_per_packet_(cols_per_packet),
          window_(
              make_layout(columns, window), params,
              [this](const LidarScan& s) {
                  out.push_back({s.frame_id, s.complete(), s.completeness(), s.packets, s.received,
                                 s.timestamp_ns});
              },
              &counters) {}

    // Sends the packet holding columns [first_col, first_col + cols_per_packet).
    void packet(std::uint32_t frame_id, std::uint32_t first_col, std::uint32_t init_id = 7,
                std::uint64_t serial = 42) {
        LidarScan* scan = window_.scan_for(frame_id, init_id, serial);
        if (!scan) return;
        std::size_t written = 0;
        for (std::uint32_t c = first_col; c < first_col + cols_per_packet_; ++c) {
            if (!window_.claim_column(*scan, c)) continue;
            scan->timestamp_ns[c] = 1000ull * frame_id + c;
            ++written;
        }
        window_.packet_done(*scan, written);
    }
    // Every packet of a frame in order, optionally skipping the packet at `skip_col`.
    void frame(std::uint32_t frame_id, std::size_t columns, int skip_col = -1) {
        for (std::uint32_t c = 0; c < columns; c += static_cast<std::uint32_t>(cols_per_packet_)) {
            if (static_cast<int>(c) != skip_col) packet(frame_id, c);
        }
    }
    void flush() { window_.flush(); }
    std::size_t in_flight() const { return window_.frames_in_flight(); }

    AssemblyCounters counters;
    std::vector<Emitted> out;

private:
    static LidarScanLayout make_layout(std::size_t columns, std::optional<ColumnWindow> w) {
        LidarScanLayout layout;
        layout.rows = 4;
        layout.columns = columns;
        layout.column_window = w;
        return layout;
    }
    std::size_t cols_per_packet_;
    FrameWindow window_;
};

TEST(FrameWindow, InOrderFrameIsEmittedCompleteAtItsLastPacket) {
    Harness h(64, 16);
    h.packet(10, 0);
    h.packet(10, 16);
    h.packet(10, 32);
    EXPECT_TRUE(h.out.empty());
    h.packet(10, 48);
    ASSERT_EQ(h.out.size(), 1u);
    EXPECT_EQ(h.out[0].frame_id, 10u);
    EXPECT_TRUE(h.out[0].complete);
    EXPECT_EQ(h.out[0].packets, 4u);
    EXPECT_DOUBLE_EQ(h.out[0].completeness, 1.0);
    EXPECT_EQ(h.out[0].timestamp_ns[63], 10063u);
    EXPECT_EQ(h.in_flight(), 0u);
    EXPECT_EQ(h.counters.frames_complete, 1u);
    EXPECT_EQ(h.counters.missing_columns, 0u);
}

TEST(FrameWindow, SixteenBitWrapAroundIsNotLoss) {
    Harness h(32, 8);
    for (std::uint32_t f : {65533u, 65534u, 65535u, 0u, 1u}) h.frame(f, 32);
    ASSERT_EQ(h.out.size(), 5u);
    const std::uint32_t expected[] = {65533, 65534, 65535, 0, 1};
    for (std::size_t i = 0; i < 5; ++i) {
        EXPECT_EQ(h.out[i].frame_id, expected[i]);
        EXPECT_TRUE(h.out[i].complete);
    }
    EXPECT_EQ(h.counters.late_packets, 0u);
    EXPECT_EQ(h.counters.resets, 0u);
    EXPECT_EQ(h.counters.frames_incomplete, 0u);
    EXPECT_EQ(h.counters.missing_columns, 0u);
}

TEST(FrameWindow, WrapAroundWithReorderAcrossTheWrap) {
    Harness h(32, 8);
    h.packet(65535, 0);
    h.packet(65535, 8);
    h.packet(65535, 16);
    h.packet(0, 0);  // the new frame starts before the old one's last packet arrives
    h.packet(65535, 24);
    h.packet(0, 8);
    h.packet(0, 16);
    h.packet(0, 24);
    ASSERT_EQ(h.out.size(), 2u);
    EXPECT_EQ(h.out[0].frame_id, 65535u);
    EXPECT_EQ(h.out[1].frame_id, 0u);
    EXPECT_TRUE(h.out[0].complete && h.out[1].complete);
    EXPECT_EQ(h.counters.late_packets, 0u);
}

TEST(FrameWindow, ThirtyTwoBitFrameIdsWrapForFusa) {
    FrameWindowParams params;
    params.frame_id_bits = 32;
    Harness h(16, 8, params);
    for (std::uint32_t f : {0xFFFFFFFEu, 0xFFFFFFFFu, 0u}) h.frame(f, 16);
    ASSERT_EQ(h.out.size(), 3u);
    EXPECT_EQ(h.out[2].frame_id, 0u);
    EXPECT_EQ(h.counters.frames_complete, 3u);
    EXPECT_EQ(h.counters.late_packets + h.counters.resets, 0u);
    // 16-bit headers: 65536 is not a new frame id but 0 again.
    Harness h16(16, 8);
    h16.packet(65536, 0);
    h16.packet(0, 8);
    ASSERT_EQ(h16.out.size(), 1u);
    EXPECT_EQ(h16.out[0].frame_id, 0u);
}

TEST(FrameWindow, ReorderedPacketsInsideTheWindowAssembleBothFrames) {
    Harness h(32, 8);
    h.packet(5, 8);
    h.packet(6, 0);
    h.packet(5, 0);
    h.packet(6, 24);
    h.packet(5, 24);
    h.packet(6, 8);
    h.packet(5, 16);  // completes 5
    ASSERT_EQ(h.out.size(), 1u);
    h.packet(6, 16);
    ASSERT_EQ(h.out.size(), 2u);
    EXPECT_EQ(h.out[0].frame_id, 5u);
    EXPECT_EQ(h.out[1].frame_id, 6u);
    EXPECT_TRUE(h.out[0].complete && h.out[1].complete);
    EXPECT_EQ(h.counters.late_packets, 0u);
}

TEST(FrameWindow, CompletingANewerFrameClosesOlderOnesFirst) {
    Harness h(32, 8);
    h.packet(5, 0);
    h.frame(6, 32);
    ASSERT_EQ(h.out.size(), 2u);
    EXPECT_EQ(h.out[0].frame_id, 5u);
    EXPECT_FALSE(h.out[0].complete);
    EXPECT_DOUBLE_EQ(h.out[0].completeness, 0.25);
    EXPECT_EQ(h.out[1].frame_id, 6u);
    h.packet(5, 8);  // straggler of an emitted frame
    EXPECT_EQ(h.counters.late_packets, 1u);
    EXPECT_EQ(h.counters.missing_columns, 24u);
}

TEST(FrameWindow, DuplicatePacketsAndColumnsAreDroppedAndCounted) {
    Harness h(32, 8);
    h.packet(3, 0);
    h.packet(3, 0);  // the whole packet again
    h.packet(3, 8);
    h.packet(3, 4);  // overlaps: columns 4..7 and 8..11 are duplicates
    h.packet(3, 16);
    h.packet(3, 24);
    ASSERT_EQ(h.out.size(), 1u);
    EXPECT_TRUE(h.out[0].complete);
    EXPECT_EQ(h.out[0].packets, 4u);
    EXPECT_EQ(h.counters.duplicate_packets, 2u);
    EXPECT_EQ(h.counters.duplicate_columns, 16u);
    EXPECT_EQ(h.out[0].timestamp_ns[4], 3004u);
}

TEST(FrameWindow, LatePacketsOfEmittedOrTooOldFramesAreDropped) {
    Harness h(32, 8);
    h.frame(10, 32);
    h.packet(10, 0);  // already emitted
    h.packet(9, 0);   // older than the emitted frame
    EXPECT_EQ(h.counters.late_packets, 2u);
    h.packet(13, 0);  // opens 13; the window (2 frames) now spans 12..13
    h.packet(11, 0);  // never seen, newer than the last emitted, but outside the window
    EXPECT_EQ(h.counters.late_packets, 3u);
    h.packet(12, 0);  // inside the window: accepted
    EXPECT_EQ(h.counters.late_packets, 3u);
    EXPECT_EQ(h.in_flight(), 2u);
    h.flush();
    ASSERT_EQ(h.out.size(), 3u);
    EXPECT_EQ(h.out[1].frame_id, 12u);
    EXPECT_EQ(h.out[2].frame_id, 13u);
}

TEST(FrameWindow, InitIdChangeMidFrameResetsAndClosesThePartialFrame) {
    Harness h(32, 8);
    h.frame(500, 32);
    h.packet(501, 0, /*init_id=*/7);
    h.packet(501, 8, 7);
    h.packet(0, 0, /*init_id=*/8);  // sensor re-initialised: frame ids restart
    ASSERT_EQ(h.out.size(), 2u);
    EXPECT_EQ(h.out[1].frame_id, 501u);
    EXPECT_FALSE(h.out[1].complete);
    EXPECT_DOUBLE_EQ(h.out[1].completeness, 0.5);
    EXPECT_EQ(h.counters.resets, 1u);
    h.packet(0, 8, 8);
    h.packet(0, 16, 8);
    h.packet(0, 24, 8);
    ASSERT_EQ(h.out.size(), 3u);
    EXPECT_EQ(h.out[2].frame_id, 0u);
    EXPECT_TRUE(h.out[2].complete);
    EXPECT_EQ(h.counters.late_packets, 0u);
}

TEST(FrameWindow, SerialNumberChangeResets) {
    Harness h(16, 8);
    h.packet(1, 0, 7, 42);
    h.packet(1, 8, 7, 43);  // same frame id, another sensor: not the same frame
    EXPECT_EQ(h.counters.resets, 1u);
    ASSERT_EQ(h.out.size(), 1u);
    EXPECT_FALSE(h.out[0].complete);
    h.flush();
    ASSERT_EQ(h.out.size(), 2u);
    EXPECT_DOUBLE_EQ(h.out[1].completeness, 0.5);
}

TEST(FrameWindow, LegacyRestartWithoutInitIdIsDetectedByAJumpBack) {
    Harness h(16, 8);
    h.frame(1000, 16);
    h.frame(1001, 16);
    h.frame(2, 16);  // 999 frames back: a restart, not a late packet
    ASSERT_EQ(h.out.size(), 3u);
    EXPECT_EQ(h.out[2].frame_id, 2u);
    EXPECT_TRUE(h.out[2].complete);
    EXPECT_EQ(h.counters.resets, 1u);
    EXPECT_EQ(h.counters.late_packets, 0u);
}

TEST(FrameWindow, MissingPacketsLowerCompletenessAndLeaveColumnsInvalid) {
    Harness h(64, 16);
    h.frame(1, 64, /*skip_col=*/32);
    h.frame(2, 64);  // completing 2 closes 1 first
    ASSERT_EQ(h.out.size(), 2u);
    EXPECT_EQ(h.out[0].frame_id, 1u);
    EXPECT_FALSE(h.out[0].complete);
    EXPECT_DOUBLE_EQ(h.out[0].completeness, 0.75);
    for (int c = 0; c < 64; ++c) {
        const bool missing = c >= 32 && c < 48;
        EXPECT_EQ(h.out[0].received[c], missing ? 0 : 1) << c;
        if (missing) {
            EXPECT_EQ(h.out[0].timestamp_ns[c], 0u) << c;
        }
    }
    EXPECT_EQ(h.counters.missing_columns, 16u);
    EXPECT_EQ(h.counters.frames_incomplete, 1u);
    EXPECT_EQ(h.counters.frames_complete, 1u);
}

TEST(FrameWindow, FramesFallingOutOfTheWindowAreClosedIncomplete) {
    Harness h(64, 16);
    h.packet(1, 0);
    h.packet(2, 0);
    EXPECT_TRUE(h.out.empty());
    h.packet(3, 0);  // 1 is now 2 frames behind: out of a 2-frame window
    ASSERT_EQ(h.out.size(), 1u);
    EXPECT_EQ(h.out[0].frame_id, 1u);
    EXPECT_DOUBLE_EQ(h.out[0].completeness, 0.25);
    h.packet(10, 0);  // a jump forward closes everything older, oldest first
    ASSERT_EQ(h.out.size(), 3u);
    EXPECT_EQ(h.out[1].frame_id, 2u);
    EXPECT_EQ(h.out[2].frame_id, 3u);
    EXPECT_EQ(h.counters.missing_columns, 3u * 48u);
}

TEST(FrameWindow, AzimuthWindowIsNotCountedAsLoss) {
    // Window [4, 11] of 16 columns; the sensor sends the packets overlapping it.
    Harness h(16, 4, {}, ColumnWindow{4, 11});
    h.packet(7, 4);
    h.packet(7, 8);
    ASSERT_EQ(h.out.size(), 1u);
    EXPECT_TRUE(h.out[0].complete);
    EXPECT_DOUBLE_EQ(h.out[0].completeness, 1.0);
    EXPECT_EQ(h.counters.missing_columns, 0u);
    // Half the window, then a newer frame: completeness counts the window only.
    h.packet(8, 4);
    h.frame(9, 16);
    ASSERT_EQ(h.out.size(), 3u);
    EXPECT_DOUBLE_EQ(h.out[1].completeness, 0.5);
    EXPECT_EQ(h.counters.missing_columns, 4u);
}

TEST(FrameWindow, AzimuthWindowWrappingThroughZero) {
    // [12, 2] of 16 columns covers 12..15 and 0..2: 7 columns.
    Harness h(16, 4, {}, ColumnWindow{12, 2});
    h.packet(3, 0);  // columns 0..3 (3 is outside the window)
    EXPECT_TRUE(h.out.empty());
    h.packet(3, 12);  // 12..15
    ASSERT_EQ(h.out.size(), 1u);
    EXPECT_TRUE(h.out[0].complete);
    EXPECT_EQ(h.counters.missing_columns, 0u);
    EXPECT_EQ(h.counters.frames_incomplete, 0u);
}

TEST(ColumnWindow, ContainsAndSize) {
    const ColumnWindow plain{1, 256};
    EXPECT_FALSE(plain.contains(0));
    EXPECT_TRUE(plain.contains(1));
    EXPECT_TRUE(plain.contains(256));
    EXPECT_FALSE(plain.contains(257));
    EXPECT_EQ(plain.size(512), 256u);
    const ColumnWindow wrapping{370, 85};
    EXPECT_TRUE(wrapping.contains(511));
    EXPECT_TRUE(wrapping.contains(0));
    EXPECT_TRUE(wrapping.contains(85));
    EXPECT_FALSE(wrapping.contains(86));
    EXPECT_FALSE(wrapping.contains(369));
    EXPECT_EQ(wrapping.size(512), 142u + 86u);
}

TEST(LidarScan, RejectsBadLayoutsAndResetsInPlace) {
    EXPECT_THROW(LidarScan(LidarScanLayout{0, 16, field_bit(ScanField::kRange), {}}),
                 std::invalid_argument);
    EXPECT_THROW(
        LidarScan(LidarScanLayout{4, 16, field_bit(ScanField::kRange), ColumnWindow{3, 16}}),
        std::invalid_argument);
    LidarScan scan(
        LidarScanLayout{4, 16, field_bit(ScanField::kRange) | field_bit(ScanField::kNearIr), {}});
    EXPECT_TRUE(scan.has(ScanField::kNearIr));
    EXPECT_FALSE(scan.has(ScanField::kSignal));
    EXPECT_EQ(scan.field_bytes(ScanField::kRange), 4u * 16u * 4u);
    EXPECT_EQ(scan.field_bytes(ScanField::kSignal), 0u);
    const auto* before = scan.range_mm.data();
    scan.range_mm[5] = 9;
    EXPECT_TRUE(scan.mark_received(3));
    EXPECT_FALSE(scan.mark_received(3));
    EXPECT_FALSE(scan.mark_received(16));
    scan.reset();
    EXPECT_EQ(scan.range_mm.data(), before);
    EXPECT_EQ(scan.range_mm[5], 0u);
    EXPECT_EQ(scan.received_expected_columns(), 0u);
    EXPECT_EQ(scan.received[3], 0);
}

TEST(FrameWindow, RejectsBadParameters) {
    AssemblyCounters counters;
    LidarScanLayout layout{4, 16, field_bit(ScanField::kRange), {}};
    FrameWindowParams zero;
    zero.frames_in_flight = 0;
    EXPECT_THROW(FrameWindow(layout, zero, nullptr, &counters), std::invalid_argument);
    FrameWindowParams bits;
    bits.frame_id_bits = 24;
    EXPECT_THROW(FrameWindow(layout, bits, nullptr, &counters), std::invalid_argument);
    EXPECT_THROW(FrameWindow(layout, {}, nullptr, nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace lidarfuse::ouster

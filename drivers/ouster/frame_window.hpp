#pragma once
// Frame bookkeeping of the scan assembler, independent of the packet wire format: which
// frame a packet belongs to, the reorder window of frames in flight, frame_id wrap-around,
// sensor restarts, late and duplicate data, and when a frame is finished.
//
// Rules (the assembler's contract, tested in tests/drivers/ouster_scan_assembler_test.cpp):
// - Up to `frames_in_flight` frames are assembled at once, each in a preallocated
//   LidarScan from a fixed pool. A packet of a frame newer than every frame in flight
//   opens it; frames that fall `frames_in_flight` or more ids behind it are closed
//   (incomplete). Packets may arrive in any order inside the window.
// - frame_id is compared by serial-number arithmetic modulo 2^frame_id_bits (16 for
//   LEGACY and STANDARD headers, 32 for FUSA): 65535 -> 0 is one step forward.
// - A frame is complete, and emitted at once, when every column inside the column window
//   has arrived. Columns outside the window are never expected, so an azimuth window is
//   not loss. Emitting frame f first closes every older frame still in flight, so frames
//   always leave in frame_id order.
// - A packet of a frame already emitted (or older than the window) is late: dropped and
//   counted. A packet more than `restart_gap_frames` behind the last emitted frame is
//   not late but a sensor restart (LEGACY headers carry no init_id to say so): reset.
// - A change of init_id or serial number resets: frames in flight are emitted incomplete
//   and the frame history is forgotten.
// - A column that already arrived in the same frame is a duplicate: dropped and counted.
// - flush() emits every frame in flight (end of a capture).
//
// No allocation after construction. Not thread safe: one instance per sensor, used by
// the one thread that receives that sensor's packets.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "drivers/ouster/assembly_counters.hpp"
#include "drivers/ouster/lidar_scan.hpp"

namespace lidarfuse::ouster {

struct FrameWindowParams {
    std::size_t frames_in_flight = 2;       // reorder window, in frames (>= 1)
    unsigned frame_id_bits = 16;            // 16 (LEGACY, STANDARD headers) or 32 (FUSA)
    std::uint32_t restart_gap_frames = 64;  // further back than this = sensor restart
};

class FrameWindow {
public:
    // Called for each finished frame. The reference is valid only during the call: the
    // buffer returns to the pool afterwards. Copy (or std::swap with a LidarScan of the
    // same layout) what must outlive it.
    using EmitFn = std::function<void(const LidarScan&)>;

    // Throws std::invalid_argument for frames_in_flight == 0, frame_id_bits not 16 or 32,
    // or an invalid layout.
    FrameWindow(const LidarScanLayout& layout, const FrameWindowParams& params, EmitFn emit,
                AssemblyCounters* counters);

    // Scan the packet with these header values writes into, opening it if needed (this
    // may emit older frames). nullptr: the packet is late (counted); drop it.
    LidarScan* scan_for(std::uint32_t frame_id, std::uint32_t init_id, std::uint64_t serial);

    // Claims column `measurement_id` of `scan` for the packet being written. false: a
    // duplicate or an out-of-range id (counted); do not write that column.
    bool claim_column(LidarScan& scan, std::uint32_t measurement_id);

    // Call once per packet after its columns are written: `columns_written` is how many
    // claim_column() calls succeeded. Emits the frame when it is complete.
    void packet_done(LidarScan& scan, std::size_t columns_written);

    // Emits every frame in flight, oldest first.
    void flush();

    std::size_t frames_in_flight() const { return in_flight_.size(); }

private:
    // Signed distance a - b in frame ids, modulo 2^frame_id_bits.
    std::int64_t frame_diff(std::uint32_t a, std::uint32_t b) const;
    void emit(LidarScan* scan);
    // Emits, oldest first, every frame in flight with frame_diff(reference, id) >= min_age.
    void close_older(std::uint32_t reference, std::int64_t min_age);
    void restart(std::uint32_t init_id, std::uint64_t serial);

    FrameWindowParams params_;
    EmitFn emit_;
    AssemblyCounters* counters_;
    std::vector<LidarScan> pool_;
    std::vector<LidarScan*> free_;
    std::vector<LidarScan*> in_flight_;  // unordered; at most frames_in_flight
    bool have_ids_ = false;
    std::uint32_t init_id_ = 0;
    std::uint64_t serial_ = 0;
    bool have_emitted_ = false;
    std::uint32_t last_emitted_ = 0;  // frame id of the newest emitted frame
};

}  // namespace lidarfuse::ouster

#pragma once
// Ouster UDP packets -> completed LidarScans for one sensor.
//
// Each datagram is classified against the sensor's packet format (IMU and wrong-size
// packets are counted and skipped, optionally the CRC-64 footer is checked), its header
// picks the frame through a FrameWindow (reorder window, frame_id wrap-around, resets on
// init_id / serial changes, late packets; see frame_window.hpp for the rules), and its
// columns are copied into the frame's staggered arrays at their measurement_id.
//
// Every finished frame and every wrong-size datagram also goes through a ModeCheck
// (mode_check.hpp): has the sensor's lidar_mode or profile changed under its metadata?
// Its verdict on a frame is known when the EmitFn sees that frame (mode_check()).
//
// Output: the EmitFn given to the constructor is called with each finished frame, in
// frame_id order, from inside add_packet() or flush(). The LidarScan reference is valid
// only during that call (the buffer goes back to a pool of `frames_in_flight` scans);
// copy or std::swap out what must outlive it.
//
// Real-time path: add_packet() never allocates and never throws (the EmitFn is the
// caller's). Not thread safe: one assembler per sensor, fed by one thread.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "drivers/ouster/frame_window.hpp"
#include "drivers/ouster/lidar_scan.hpp"
#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/mode_check.hpp"
#include "drivers/ouster/packet_format.hpp"

namespace lidarfuse::ouster {

struct ScanAssemblerParams {
    // Frames assembled at once; frame_id_bits is ignored here (16, or 32 for FUSA
    // headers, is taken from the profile).
    FrameWindowParams window;
    // Drop lidar packets whose CRC-64 footer is filled in and wrong (STANDARD and FUSA
    // headers). A zero footer, or the 0xDEADBEEF0000C0DE marker that FW 2.2-2.4 write
    // instead of a CRC, means "not filled" and is never an error.
    bool check_crc = true;
    ModeCheckParams mode_check;
};

// What add_packet() did with one datagram.
enum class PacketOutcome : std::uint8_t {
    kAssembled,     // at least one column went into a frame
    kImu,           // IMU packet: skipped
    kWrongSize,     // skipped
    kWrongProfile,  // lidar size, but the header is not a lidar packet of this profile
    kCrcError,      // dropped
    kLate,          // frame already emitted or older than the window: dropped
    kDuplicate,     // no new column (all duplicates or bad measurement ids): dropped
};
const char* to_string(PacketOutcome outcome);

// LidarScan layout for a sensor: H x W, the profile's fields, the column window.
LidarScanLayout scan_layout(const SensorInfo& info);
// The LidarScan fields a packet profile carries.
std::uint32_t scan_fields(UdpProfileLidar profile);

class ScanAssembler {
public:
    using EmitFn = FrameWindow::EmitFn;

    // Throws std::invalid_argument when the metadata cannot describe a packet format.
    ScanAssembler(const SensorInfo& info, const ScanAssemblerParams& params, EmitFn emit);
    // The window's callback points at this object.
    ScanAssembler(const ScanAssembler&) = delete;
    ScanAssembler& operator=(const ScanAssembler&) = delete;

    PacketOutcome add_packet(const std::uint8_t* data, std::size_t size);
    // Emits every frame still in flight (end of a capture, or before a pause).
    void flush();

    const AssemblyCounters& counters() const { return counters_; }
    const PacketFormat& format() const { return format_; }
    const ModeCheck& mode_check() const { return mode_; }
    const LidarScanLayout& layout() const { return layout_; }

private:
    // add_packet's steps, defined in scan_assembler.cpp (the only caller) and inlined there.
    // False when the footer holds a CRC-64 and it is wrong (counted).
    inline bool crc_ok(const std::uint8_t* data);
    // The frame the packet's header picks (a reset forgets the mode check's last frame);
    // nullptr when the packet is late.
    inline LidarScan* frame_of(const std::uint8_t* data);
    // The packet's columns the window has not seen yet; how many.
    inline std::size_t write_columns(const std::uint8_t* data, LidarScan* scan);
    // The pixels of the packet's columns [first, first + count), the first at measurement
    // id m, into every field the scan has.
    inline void write_pixels(const std::uint8_t* data, int first, int count, std::uint16_t m,
                             LidarScan* scan) const;

    PacketFormat format_;
    LidarScanLayout layout_;
    ScanAssemblerParams params_;
    AssemblyCounters counters_;
    ModeCheck mode_;
    EmitFn emit_;
    FrameWindow window_;  // last: its callback uses mode_ and emit_
    // write_columns' scratch: per column of a packet, its measurement id, or -1 when the
    // window did not take it.
    std::vector<int> claimed_;
};

}  // namespace lidarfuse::ouster

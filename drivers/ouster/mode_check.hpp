#pragma once
// Does the data a sensor sends still match its metadata's lidar_mode and UDP profile?
//
// A sensor reconfigured under the daemon (someone switched 1024x20 to 512x20, 2048x10 or
// another profile on its web page) keeps sending, but the metadata the daemon loaded at
// start-up no longer describes its packets: columns land at wrong azimuths, frames never
// complete or complete with the wrong columns. The ModeCheck looks at what the assembler
// sees and says so:
// - column spacing: over the columns a frame received, (t(m_last) - t(m_first)) /
//   (m_last - m_first) against 1 / (frames_per_second * columns_per_frame). A mode with
//   other columns or another rate changes it (512x20 data for 1024x20 metadata: 2x).
// - frame period: the extrapolated time of column 0 of consecutive frames against
//   1 / frames_per_second (512x20 data for 1024x10 metadata has the same column spacing,
//   but frames twice as often).
// - measurement ids at or beyond columns_per_frame in a frame.
// - packet size: a profile change changes the lidar packet size, so every datagram is
//   the wrong size; `packet_run_to_flag` of them in a row (no lidar packet between).
// A frame disagrees when any of these is off by more than `tolerance`; frames with too
// few columns or non-increasing column timestamps give no verdict. One disagreeing frame
// is not enough (a sensor clock jump inside a frame looks the same): the sensor is
// flagged after `frames_to_flag` disagreeing frames in a row, and trusted again after
// `frames_to_clear` agreeing frames in a row.
//
// No allocation, never throws after construction. Not thread safe: owned by one
// ScanAssembler, used by its thread.

#include <cstddef>
#include <cstdint>
#include <string>

#include "drivers/ouster/lidar_scan.hpp"

namespace lidarfuse::ouster {

struct ModeCheckParams {
    double tolerance = 0.25;                  // |observed / expected - 1| above this: disagrees
    std::uint32_t frames_to_flag = 3;         // disagreeing frames in a row before flagging
    std::uint32_t frames_to_clear = 3;        // agreeing frames in a row before trusting again
    std::uint32_t min_columns = 8;            // received columns (and id span) a verdict needs
    std::uint32_t max_frame_gap = 8;          // frame period only across at most this many ids
    std::uint32_t packet_frames_to_flag = 3;  // wrong-size run = this many frames of packets
};

// What was seen that disagrees with the metadata (the latest such frame or packet run).
enum class ModeEvidence : std::uint8_t {
    kNone,
    kColumnSpacing,
    kFramePeriod,
    kColumnsBeyondWidth,
    kPacketSize,
};
const char* to_string(ModeEvidence evidence);

struct ModeObservation {
    ModeEvidence evidence = ModeEvidence::kNone;
    double column_spacing_ns = 0.0;                   // observed; 0 when not measured
    double frame_period_ns = 0.0;                     // observed; 0 when not measured
    std::uint32_t first_column = 0, last_column = 0;  // lowest / highest id received
    std::uint32_t bad_columns = 0;                    // ids >= columns_per_frame in the frame
    std::size_t packet_bytes = 0;  // kPacketSize: size of the wrong-size datagrams
    std::uint64_t packet_run = 0;  // kPacketSize: how many in a row
};

// What the metadata says the data should look like.
struct ModeExpectation {
    std::uint32_t columns_per_frame = 0;
    int frames_per_second = 0;
    std::size_t lidar_packet_bytes = 0;
    std::uint32_t packets_per_frame = 0;  // columns_per_frame / columns_per_packet
    std::string lidar_mode;               // "1024x20", for the text
    std::string profile;                  // "RNG19_RFL8_SIG16_NIR16", for the text
    double column_spacing_ns() const;
    double frame_period_ns() const;
};

// One line for a log or a diagnostic: what was seen, then what the metadata says.
std::string describe(const ModeObservation& seen, const ModeExpectation& expected);

class ModeCheck {
public:
    enum class Verdict : std::uint8_t { kUnknown, kAgrees, kDisagrees };

    ModeCheck(const ModeExpectation& expected, unsigned frame_id_bits,
              const ModeCheckParams& params);

    // A finished frame (any completeness). Returns its verdict; may flag or clear.
    Verdict observe_frame(const LidarScan& scan);
    // A datagram of neither lidar nor IMU size / a lidar packet of this profile.
    void observe_wrong_size(std::size_t bytes);
    void observe_lidar_packet() { wrong_size_run_ = 0; }
    // The sensor restarted (frame ids and clock start over): no frame period across it.
    void forget_previous_frame() { have_previous_ = false; }

    // True while the data is flagged as not matching the metadata.
    bool mismatch() const { return mismatch_; }
    // The last frame disagreed, or the sensor is flagged: do not use that frame.
    bool reject_last_frame() const { return mismatch_ || last_verdict_ == Verdict::kDisagrees; }
    const ModeObservation& last_disagreement() const { return last_disagreement_; }
    const ModeExpectation& expected() const { return expected_; }
    std::uint64_t frames_disagreeing() const { return frames_disagreeing_; }
    std::uint64_t mismatches() const { return mismatches_; }  // times flagged

private:
    void disagree(const ModeObservation& seen);
    void agree();

    ModeExpectation expected_;
    ModeCheckParams params_;
    unsigned frame_id_bits_;
    bool mismatch_ = false;
    Verdict last_verdict_ = Verdict::kUnknown;
    std::uint32_t disagree_run_ = 0, agree_run_ = 0;
    std::uint64_t wrong_size_run_ = 0;
    bool have_previous_ = false;
    std::uint32_t previous_frame_id_ = 0;
    std::uint64_t previous_first_t_ns_ = 0;  // timestamp of its lowest received column
    std::uint32_t previous_first_column_ = 0;
    ModeObservation last_disagreement_;
    std::uint64_t frames_disagreeing_ = 0, mismatches_ = 0;
};

}  // namespace lidarfuse::ouster

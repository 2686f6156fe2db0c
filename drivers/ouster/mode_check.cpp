#include "drivers/ouster/mode_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace lidarfuse::ouster {

namespace {

// a - b for timestamps anywhere in 0..2^64-1, as a signed difference (modulo 2^64).
double signed_diff_ns(std::uint64_t a, std::uint64_t b) {
    return static_cast<double>(static_cast<std::int64_t>(a - b));
}

bool off_by_more_than(double observed, double expected, double tolerance) {
    return expected > 0.0 && std::fabs(observed / expected - 1.0) > tolerance;
}

}  // namespace

const char* to_string(ModeEvidence evidence) {
    switch (evidence) {
        case ModeEvidence::kNone:
            return "none";
        case ModeEvidence::kColumnSpacing:
            return "column_spacing";
        case ModeEvidence::kFramePeriod:
            return "frame_period";
        case ModeEvidence::kColumnsBeyondWidth:
            return "columns_beyond_width";
        case ModeEvidence::kPacketSize:
            return "packet_size";
    }
    return "unknown";
}

double ModeExpectation::column_spacing_ns() const {
    return frames_per_second > 0 && columns_per_frame > 0
               ? 1e9 / (static_cast<double>(frames_per_second) * columns_per_frame)
               : 0.0;
}

double ModeExpectation::frame_period_ns() const {
    return frames_per_second > 0 ? 1e9 / frames_per_second : 0.0;
}

std::string describe(const ModeObservation& seen, const ModeExpectation& expected) {
    char text[512];
    if (seen.evidence == ModeEvidence::kPacketSize) {
        std::snprintf(text, sizeof text,
                      "%llu datagrams in a row of %zu bytes; metadata (%s, %s) says lidar packets "
                      "of %zu bytes",
                      static_cast<unsigned long long>(seen.packet_run), seen.packet_bytes,
                      expected.profile.c_str(), expected.lidar_mode.c_str(),
                      expected.lidar_packet_bytes);
        return text;
    }
    char period[64] = "not measured";
    if (seen.frame_period_ns > 0.0)
        std::snprintf(period, sizeof period, "%.1f ms", seen.frame_period_ns * 1e-6);
    std::snprintf(text, sizeof text,
                  "%s: columns %u..%u%s, column spacing %.1f us, frame period %s; metadata (%s) "
                  "says columns 0..%u, %.1f us, %.1f ms",
                  to_string(seen.evidence), seen.first_column, seen.last_column,
                  seen.bad_columns ? " and ids beyond the width" : "",
                  seen.column_spacing_ns * 1e-3, period, expected.lidar_mode.c_str(),
                  expected.columns_per_frame > 0 ? expected.columns_per_frame - 1 : 0,
                  expected.column_spacing_ns() * 1e-3, expected.frame_period_ns() * 1e-6);
    return text;
}

ModeCheck::ModeCheck(const ModeExpectation& expected, unsigned frame_id_bits,
                     const ModeCheckParams& params)
    : expected_(expected), params_(params), frame_id_bits_(frame_id_bits) {}

ModeCheck::Verdict ModeCheck::observe_frame(const LidarScan& scan) {
    ModeObservation seen;
    seen.bad_columns = scan.bad_columns;
    std::size_t received = 0;
    bool any = false;
    for (std::size_t m = 0; m < scan.columns(); ++m) {
        if (!scan.received[m]) continue;
        ++received;
        if (!any) seen.first_column = static_cast<std::uint32_t>(m);
        seen.last_column = static_cast<std::uint32_t>(m);
        any = true;
    }
    const std::uint32_t span = seen.last_column - seen.first_column;
    const double t_span_ns = any ? signed_diff_ns(scan.timestamp_ns[seen.last_column],
                                                  scan.timestamp_ns[seen.first_column])
                                 : 0.0;
    const bool measurable =
        received >= params_.min_columns && span >= params_.min_columns && t_span_ns > 0.0;
    if (!measurable && seen.bad_columns == 0) {
        last_verdict_ = Verdict::kUnknown;
        return last_verdict_;
    }
    if (measurable) {
        seen.column_spacing_ns = t_span_ns / span;
        if (have_previous_) {
            const std::uint32_t id_diff = scan.frame_id - previous_frame_id_;
            const std::uint32_t frames =
                frame_id_bits_ == 16 ? static_cast<std::uint16_t>(id_diff) : id_diff;
            if (frames >= 1 && frames <= params_.max_frame_gap) {
                // Both frames' column 0, extrapolated with the metadata's column spacing.
                const double columns =
                    static_cast<double>(seen.first_column) - previous_first_column_;
                const double start_diff_ns =
                    signed_diff_ns(scan.timestamp_ns[seen.first_column], previous_first_t_ns_) -
                    columns * expected_.column_spacing_ns();
                seen.frame_period_ns = start_diff_ns / frames;
            }
        }
        have_previous_ = true;
        previous_frame_id_ = scan.frame_id;
        previous_first_t_ns_ = scan.timestamp_ns[seen.first_column];
        previous_first_column_ = seen.first_column;
    }
    if (seen.bad_columns > 0) {
        seen.evidence = ModeEvidence::kColumnsBeyondWidth;
    } else if (off_by_more_than(seen.column_spacing_ns, expected_.column_spacing_ns(),
                                params_.tolerance)) {
        seen.evidence = ModeEvidence::kColumnSpacing;
    } else if (seen.frame_period_ns != 0.0 &&
               off_by_more_than(seen.frame_period_ns, expected_.frame_period_ns(),
                                params_.tolerance)) {
        seen.evidence = ModeEvidence::kFramePeriod;
    }
    if (seen.evidence == ModeEvidence::kNone) {
        agree();
    } else {
        disagree(seen);
    }
    return last_verdict_;
}

void ModeCheck::observe_wrong_size(std::size_t bytes) {
    ++wrong_size_run_;
    const std::uint64_t needed = static_cast<std::uint64_t>(params_.packet_frames_to_flag) *
                                 std::max<std::uint32_t>(1, expected_.packets_per_frame);
    if (wrong_size_run_ < needed) return;
    ModeObservation seen;
    seen.evidence = ModeEvidence::kPacketSize;
    seen.packet_bytes = bytes;
    seen.packet_run = wrong_size_run_;
    last_disagreement_ = seen;
    if (!mismatch_) {
        mismatch_ = true;
        ++mismatches_;
    }
    agree_run_ = 0;
}

void ModeCheck::disagree(const ModeObservation& seen) {
    last_verdict_ = Verdict::kDisagrees;
    last_disagreement_ = seen;
    ++frames_disagreeing_;
    agree_run_ = 0;
    if (++disagree_run_ >= params_.frames_to_flag && !mismatch_) {
        mismatch_ = true;
        ++mismatches_;
    }
}

void ModeCheck::agree() {
    last_verdict_ = Verdict::kAgrees;
    disagree_run_ = 0;
    if (mismatch_ && ++agree_run_ >= params_.frames_to_clear) {
        mismatch_ = false;
        agree_run_ = 0;
    }
}

}  // namespace lidarfuse::ouster

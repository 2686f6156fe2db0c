#include "drivers/ouster/frame_window.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

namespace lidarfuse::ouster {

FrameWindow::FrameWindow(const LidarScanLayout& layout, const FrameWindowParams& params,
                         EmitFn emit, AssemblyCounters* counters)
    : params_(params), emit_(std::move(emit)), counters_(counters) {
    if (params.frames_in_flight == 0) {
        throw std::invalid_argument("FrameWindow: frames_in_flight must be at least 1");
    }
    if (params.frame_id_bits != 16 && params.frame_id_bits != 32) {
        throw std::invalid_argument("FrameWindow: frame_id_bits must be 16 or 32, got " +
                                    std::to_string(params.frame_id_bits));
    }
    if (!counters_) throw std::invalid_argument("FrameWindow: counters must not be null");
    pool_.reserve(params.frames_in_flight);
    for (std::size_t i = 0; i < params.frames_in_flight; ++i) pool_.emplace_back(layout);
    free_.reserve(pool_.size());
    in_flight_.reserve(pool_.size());
    for (auto& scan : pool_) free_.push_back(&scan);
}

std::int64_t FrameWindow::frame_diff(std::uint32_t a, std::uint32_t b) const {
    if (params_.frame_id_bits == 16) {
        return static_cast<std::int16_t>(static_cast<std::uint16_t>(a - b));
    }
    return static_cast<std::int32_t>(a - b);
}

LidarScan* FrameWindow::scan_for(std::uint32_t frame_id, std::uint32_t init_id,
                                 std::uint64_t serial) {
    if (params_.frame_id_bits == 16) frame_id &= 0xFFFFu;
    if (!have_ids_) {
        have_ids_ = true;
        init_id_ = init_id;
        serial_ = serial;
    } else if (init_id != init_id_ || serial != serial_) {
        restart(init_id, serial);
    }
    for (LidarScan* scan : in_flight_) {
        if (scan->frame_id == frame_id) return scan;
    }

    // The newest frame seen so far: decides between late, restart and a new frame.
    bool have_newest = have_emitted_;
    std::uint32_t newest = last_emitted_;
    for (const LidarScan* scan : in_flight_) {
        if (!have_newest || frame_diff(scan->frame_id, newest) > 0) newest = scan->frame_id;
        have_newest = true;
    }
    if (have_newest &&
        frame_diff(newest, frame_id) > static_cast<std::int64_t>(params_.restart_gap_frames)) {
        restart(init_id, serial);  // far in the past: the sensor started counting again
    } else {
        if (have_emitted_ && frame_diff(frame_id, last_emitted_) <= 0) {
            ++counters_->late_packets;
            return nullptr;
        }
        const auto window = static_cast<std::int64_t>(params_.frames_in_flight);
        for (const LidarScan* scan : in_flight_) {
            if (frame_diff(scan->frame_id, frame_id) >= window) {
                ++counters_->late_packets;  // older than the reorder window
                return nullptr;
            }
        }
        close_older(frame_id, window);
    }
    if (free_.empty()) close_older(frame_id, 1);  // defensive; the window rules prevent it

    LidarScan* scan = free_.back();
    free_.pop_back();
    scan->reset();
    scan->frame_id = frame_id;
    scan->init_id = init_id;
    scan->serial = serial;
    in_flight_.push_back(scan);
    return scan;
}

bool FrameWindow::claim_column(LidarScan& scan, std::uint32_t measurement_id) {
    if (measurement_id >= scan.columns()) {
        ++counters_->bad_columns;
        ++scan.bad_columns;
        return false;
    }
    if (!scan.mark_received(measurement_id)) {
        ++counters_->duplicate_columns;
        ++scan.duplicate_columns;
        return false;
    }
    return true;
}

void FrameWindow::packet_done(LidarScan& scan, std::size_t columns_written) {
    if (columns_written == 0) {
        ++counters_->duplicate_packets;
        return;
    }
    ++scan.packets;
    if (scan.complete()) {
        close_older(scan.frame_id, 1);
        emit(&scan);
    }
}

void FrameWindow::flush() {
    if (in_flight_.empty()) return;
    std::uint32_t newest = in_flight_.front()->frame_id;
    for (const LidarScan* scan : in_flight_) {
        if (frame_diff(scan->frame_id, newest) > 0) newest = scan->frame_id;
    }
    close_older(newest, std::numeric_limits<std::int64_t>::min());
}

void FrameWindow::close_older(std::uint32_t reference, std::int64_t min_age) {
    for (;;) {
        LidarScan* oldest = nullptr;
        std::int64_t oldest_age = 0;
        for (LidarScan* scan : in_flight_) {
            const std::int64_t age = frame_diff(reference, scan->frame_id);
            if (age >= min_age && (!oldest || age > oldest_age)) {
                oldest = scan;
                oldest_age = age;
            }
        }
        if (!oldest) return;
        emit(oldest);
    }
}

void FrameWindow::emit(LidarScan* scan) {
    in_flight_.erase(std::find(in_flight_.begin(), in_flight_.end(), scan));
    if (scan->complete()) {
        ++counters_->frames_complete;
    } else {
        ++counters_->frames_incomplete;
        counters_->missing_columns += scan->expected_columns() - scan->received_expected_columns();
    }
    if (!have_emitted_ || frame_diff(scan->frame_id, last_emitted_) > 0) {
        last_emitted_ = scan->frame_id;
    }
    have_emitted_ = true;
    // Return the buffer to the pool even if the callback throws.
    struct Release {
        std::vector<LidarScan*>& free;
        LidarScan* scan;
        ~Release() { free.push_back(scan); }
    } release{free_, scan};
    if (emit_) emit_(*scan);
}

void FrameWindow::restart(std::uint32_t init_id, std::uint64_t serial) {
    if (!in_flight_.empty()) flush();
    ++counters_->resets;
    have_emitted_ = false;
    init_id_ = init_id;
    serial_ = serial;
}

}  // namespace lidarfuse::ouster

#pragma once
// Groups one scan per sensor into a frame by sensor timestamp (PAPER.md step 1: members
// differ by at most max_offset_ns, 1/SR by default) with a deadline: when a sensor is late
// or missing, the frame leaves without it and says so (`included`). Frames leave in
// timestamp order and never go backwards; a scan older than the last frame that left is
// dropped and counted (so is one that belonged to that frame), unless it is older by more than
// `reset_jump_ns` (a looped replay, a sensor clock reset), which resets the synchroniser instead.
//
// Times: sensor timestamps (ns, after each sensor's configured offset) decide membership;
// the deadline runs on the caller's monotonic clock (ns), so a wall-clock jump has no
// effect (offline, the capture timestamps serve as that clock). Single-threaded: one
// thread owns it. Items (e.g. scan buffers) move
// in and out; nothing is allocated per scan once the open-frame list has warmed up.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

namespace lidarfuse::core {

struct SyncParams {
    std::int64_t max_offset_ns = 50'000'000;  // 1/SR at 20 Hz
    std::int64_t deadline_ns = 60'000'000;    // wait this long (monotonic) for late members
    std::int64_t reset_jump_ns = 2'000'000'000;
    std::vector<std::int64_t> time_offset_ns;  // per sensor, added to its timestamps
};

// Offline grouping of a recorded capture (`fuse`, `calibrate`), where capture time is the
// clock: members within one frame period of each other, late members waited for 1.5 periods.
inline SyncParams offline_sync_params(int frames_per_second) {
    SyncParams params;
    params.max_offset_ns = 1'000'000'000LL / (frames_per_second > 0 ? frames_per_second : 1);
    params.deadline_ns = params.max_offset_ns * 3 / 2;
    return params;
}

struct SyncCounters {
    std::uint64_t frames_complete = 0;
    std::uint64_t frames_partial = 0;
    std::uint64_t late_dropped = 0;  // older than the last frame that left
    std::uint64_t replaced = 0;      // a second scan of a sensor for one open frame
    std::uint64_t resets = 0;        // backward jumps larger than reset_jump_ns
};

template <typename T>
struct SyncedFrame {
    std::int64_t t_ns = 0;                  // reference time: the earliest member's timestamp
    std::vector<std::optional<T>> members;  // one slot per sensor, empty when not included
    std::size_t included() const {
        std::size_t n = 0;
        for (const auto& m : members) n += m.has_value() ? 1 : 0;
        return n;
    }
};

template <typename T>
class FrameSynchroniser {
public:
    FrameSynchroniser(std::size_t sensors, SyncParams params)
        : sensors_(sensors), params_(std::move(params)) {
        params_.time_offset_ns.resize(sensors_, 0);
    }

    // The root's frame rate became known or changed (a sensor named by hostname): frames
    // opened from now on use the new largest offset.
    void set_max_offset_ns(std::int64_t max_offset_ns) { params_.max_offset_ns = max_offset_ns; }
    std::int64_t max_offset_ns() const { return params_.max_offset_ns; }

    // A completed scan of `sensor` with its sensor timestamp; `now_ns` is monotonic.
    void push(std::size_t sensor, std::int64_t sensor_t_ns, std::int64_t now_ns, T item) {
        if (sensor >= sensors_) return;
        const std::int64_t t = sensor_t_ns + params_.time_offset_ns[sensor];
        // A scan within half an offset after the last output belonged to that frame.
        if (last_out_ns_ && t < *last_out_ns_ + params_.max_offset_ns / 2) {
            if (*last_out_ns_ - t > params_.reset_jump_ns) {
                reset();
                ++counters_.resets;
            } else {
                ++counters_.late_dropped;
                return;
            }
        }
        // Join the open frame nearest in time whose reference is within max_offset.
        Open* best = nullptr;
        std::int64_t best_gap = 0;
        for (auto& open : open_) {
            const std::int64_t gap =
                t > open.frame.t_ns ? t - open.frame.t_ns : open.frame.t_ns - t;
            if (gap < params_.max_offset_ns && (!best || gap < best_gap)) {
                best = &open;
                best_gap = gap;
            }
        }
        if (!best) {
            open_.push_back(
                Open{SyncedFrame<T>{t, std::vector<std::optional<T>>(sensors_)}, now_ns});
            best = &open_.back();
        } else if (best->frame.members[sensor].has_value()) {
            ++counters_.replaced;  // keep the newer scan of this sensor
        }
        best->frame.members[sensor] = std::move(item);
        if (t < best->frame.t_ns) best->frame.t_ns = t;
    }

    // Frames ready to leave at monotonic time `now_ns`: complete ones, and partial ones
    // whose deadline passed. Frames leave oldest first; an older open frame leaves (partial)
    // before a newer complete one, so output time never goes backwards.
    std::optional<SyncedFrame<T>> poll(std::int64_t now_ns) {
        if (open_.empty()) return std::nullopt;
        auto oldest = open_.begin();
        for (auto it = open_.begin(); it != open_.end(); ++it) {
            if (it->frame.t_ns < oldest->frame.t_ns) oldest = it;
        }
        bool any_complete_newer = false;
        for (const auto& open : open_) {
            any_complete_newer = any_complete_newer || open.frame.included() == sensors_;
        }
        const bool complete = oldest->frame.included() == sensors_;
        const bool expired = now_ns - oldest->opened_ns >= params_.deadline_ns;
        if (!complete && !expired && !any_complete_newer) return std::nullopt;
        SyncedFrame<T> out = std::move(oldest->frame);
        open_.erase(oldest);
        (complete ? counters_.frames_complete : counters_.frames_partial)++;
        last_out_ns_ = out.t_ns;
        return out;
    }

    // The earliest monotonic time at which poll() could let an open frame leave without
    // another push (its deadline); nothing while no frame is open.
    std::optional<std::int64_t> next_deadline_ns() const {
        std::optional<std::int64_t> next;
        for (const auto& open : open_) {
            const std::int64_t due = open.opened_ns + params_.deadline_ns;
            if (!next || due < *next) next = due;
        }
        return next;
    }

    // Drops open frames and forgets the last output time (after a clock jump or restart).
    void reset() {
        open_.clear();
        last_out_ns_.reset();
    }

    const SyncCounters& counters() const { return counters_; }
    std::size_t open_frames() const { return open_.size(); }

private:
    struct Open {
        SyncedFrame<T> frame;
        std::int64_t opened_ns;  // monotonic time of its first member
    };

    std::size_t sensors_;
    SyncParams params_;
    std::deque<Open> open_;
    std::optional<std::int64_t> last_out_ns_;
    SyncCounters counters_;
};

}  // namespace lidarfuse::core

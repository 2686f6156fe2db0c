#pragma once
// Spare frame buffers handed back by the thread that is done with them to the thread that
// fills them next: a scan's vectors from fusion to its receiver, a fused cloud from output
// to fusion.
//
// Why: a frame's buffers are 0.2-5 MB each, above glibc's mmap threshold, and each is
// made in one thread and freed in another a frame later. Freed, it was unmapped; made
// again, its pages were faulted in again, every frame, in every thread that writes one.
// A kept buffer keeps its pages. At most `max_kept` are kept, so the memory held stays
// bounded by the frames in flight, whatever the allocator does.
//
// Thread safe: any thread may give or take (a mutex; a handful of calls per frame).

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

namespace lidarfuse::daemon {

struct BufferPoolCounters {
    std::uint64_t reused = 0;     // take() handed out a kept buffer
    std::uint64_t missed = 0;     // take() found none: the caller allocates
    std::uint64_t discarded = 0;  // give() found max_kept kept: the buffer was freed
};

template <typename T>
class BufferPool {
public:
    explicit BufferPool(std::size_t max_kept) : max_kept_(max_kept) { kept_.reserve(max_kept); }

    // The buffer given last, as it was given (the caller overwrites or clears it), or
    // nothing when none is kept.
    std::optional<T> take() {
        std::lock_guard<std::mutex> lock(mutex_);
        if (kept_.empty()) {
            ++counters_.missed;
            return std::nullopt;
        }
        std::optional<T> out(std::move(kept_.back()));
        kept_.pop_back();
        ++counters_.reused;
        return out;
    }

    // Keeps `buffer` for a later take(), or frees it (outside the lock) when full.
    void give(T buffer) {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            if (kept_.size() < max_kept_) {
                kept_.push_back(std::move(buffer));
                return;
            }
            ++counters_.discarded;
        }
        // `buffer` is destroyed here, after the lock is released.
    }

    std::size_t kept() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return kept_.size();
    }
    BufferPoolCounters counters() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return counters_;
    }

private:
    const std::size_t max_kept_;
    mutable std::mutex mutex_;
    std::vector<T> kept_;  // never above max_kept_ (reserved: give() never allocates)
    BufferPoolCounters counters_;
};

}  // namespace lidarfuse::daemon

#pragma once
// Bounded queue between two pipeline threads that never blocks its producer: when full,
// push() discards the OLDEST item and counts it, so a slow consumer costs old frames,
// never fresh data. One producer and one consumer thread.
//
// Lock-free on both sides: a ring of slots, each with a sequence number (Vyukov's bounded
// queue). Dropping the oldest means the producer dequeues one item itself, which is why
// the head index is claimed with a compare-and-swap even with a single consumer.
// The consumer may sleep in pop_wait(); the producer wakes it only when it is asleep, and
// close() wakes it for shutdown. A consumer of several queues sleeps on a Doorbell instead,
// which every push rings (set_doorbell).

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include "daemon/doorbell.hpp"

namespace lidarfuse::daemon {

template <typename T>
class DropOldestQueue {
public:
    // Holds at most `capacity` items (at least 1): a frame queue of depth 1 keeps only the
    // newest frame. The ring under it has a power of two of slots, at least 2.
    explicit DropOldestQueue(std::size_t capacity)
        : capacity_(std::max<std::size_t>(1, capacity)), mask_(round_up(capacity_) - 1) {
        slots_ = std::make_unique<Slot[]>(mask_ + 1);
        for (std::size_t i = 0; i <= mask_; ++i)
            slots_[i].sequence.store(i, std::memory_order_relaxed);
    }

    std::size_t capacity() const { return capacity_; }

    // Every later push() also rings `bell` (null: none). Set before the producer starts.
    void set_doorbell(Doorbell* bell) { doorbell_ = bell; }

    // Producer. Returns false when an older item had to be dropped to make room.
    bool push(T item) {
        bool dropped_one = false;
        for (;;) {
            // Full: capacity items not yet claimed by the consumer. Otherwise a failed
            // try_push means the consumer has claimed the slot we need and is moving its
            // item out: let it finish.
            const std::size_t head = head_.load(std::memory_order_acquire);
            if (tail_.load(std::memory_order_relaxed) - head >= capacity_) {
                if (try_pop_internal()) {
                    dropped_.fetch_add(1, std::memory_order_relaxed);
                    dropped_one = true;
                }
            } else if (try_push(item)) {
                break;
            } else {
                std::this_thread::yield();
            }
        }
        pushed_.fetch_add(1, std::memory_order_relaxed);
        if (waiting_.load(std::memory_order_seq_cst)) {
            std::lock_guard<std::mutex> lock(mutex_);
            cv_.notify_one();
        }
        if (doorbell_) doorbell_->ring();
        return !dropped_one;
    }

    // Consumer: the oldest item, or nothing when empty.
    std::optional<T> try_pop() { return try_pop_internal(); }

    // Consumer: waits up to `timeout` for an item; returns nothing on time-out or close().
    template <class Rep, class Period>
    std::optional<T> pop_wait(std::chrono::duration<Rep, Period> timeout) {
        if (auto item = try_pop_internal()) return item;
        std::unique_lock<std::mutex> lock(mutex_);
        waiting_.store(true, std::memory_order_seq_cst);
        std::optional<T> item;
        cv_.wait_for(lock, timeout, [&] {
            item = try_pop_internal();
            return item.has_value() || closed_.load(std::memory_order_acquire);
        });
        waiting_.store(false, std::memory_order_seq_cst);
        return item;
    }

    // Wakes a waiting consumer; later pop_wait() calls return at once when empty.
    void close() {
        closed_.store(true, std::memory_order_release);
        std::lock_guard<std::mutex> lock(mutex_);
        cv_.notify_all();
    }
    bool closed() const { return closed_.load(std::memory_order_acquire); }

    // Consumer: whether nothing waits (a producer may push right after: a hint).
    bool empty() const {
        return head_.load(std::memory_order_acquire) == tail_.load(std::memory_order_acquire);
    }

    std::uint64_t pushed() const { return pushed_.load(std::memory_order_relaxed); }
    std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

private:
    struct alignas(64) Slot {
        std::atomic<std::size_t> sequence{0};
        std::optional<T> value;
    };

    static std::size_t round_up(std::size_t n) {
        std::size_t p = 2;
        while (p < n) p <<= 1;
        return p;
    }

    bool try_push(T& item) {
        const std::size_t pos = tail_.load(std::memory_order_relaxed);
        Slot& slot = slots_[pos & mask_];
        const std::size_t seq = slot.sequence.load(std::memory_order_acquire);
        if (seq != pos) return false;  // the consumer is still moving this slot's item out
        slot.value.emplace(std::move(item));
        tail_.store(pos + 1, std::memory_order_relaxed);
        slot.sequence.store(pos + 1, std::memory_order_release);
        return true;
    }

    std::optional<T> try_pop_internal() {
        std::size_t pos = head_.load(std::memory_order_relaxed);
        for (;;) {
            Slot& slot = slots_[pos & mask_];
            const std::size_t seq = slot.sequence.load(std::memory_order_acquire);
            const auto diff =
                static_cast<std::ptrdiff_t>(seq) - static_cast<std::ptrdiff_t>(pos + 1);
            if (diff < 0) return std::nullopt;  // empty
            if (diff > 0) {                     // another taker moved on; reload
                pos = head_.load(std::memory_order_relaxed);
                continue;
            }
            if (head_.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) {
                std::optional<T> out(std::move(slot.value));
                slot.value.reset();
                slot.sequence.store(pos + mask_ + 1, std::memory_order_release);
                return out;
            }
        }
    }

    const std::size_t capacity_;
    const std::size_t mask_;
    std::unique_ptr<Slot[]> slots_;
    alignas(64) std::atomic<std::size_t> head_{0};
    alignas(64) std::atomic<std::size_t> tail_{0};
    std::atomic<std::uint64_t> pushed_{0};
    std::atomic<std::uint64_t> dropped_{0};
    std::atomic<bool> waiting_{false};
    std::atomic<bool> closed_{false};
    std::mutex mutex_;
    std::condition_variable cv_;
    Doorbell* doorbell_ = nullptr;
};

}  // namespace lidarfuse::daemon

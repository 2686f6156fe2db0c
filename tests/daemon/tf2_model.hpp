#pragma once
// A model of tf2's buffer (tf2::BufferCore and TimeCache, ROS 2) for tests: what a tf2
// listener makes of the daemon's rt/tf and rt/tf_static, without a ROS install.
//
// Rules modelled:
// - each child frame has one cache, static or dynamic; a sample arriving on the other
//   topic replaces the cache (its history is lost);
// - a dynamic sample older than the newest by more than the cache time (10 s) is dropped
//   (TF_OLD_DATA), and so is one with a stamp the cache already holds (TF_REPEATED_DATA);
// - a dynamic frame resolves at time t only with a sample at t or two samples around it
//   (tf2 interpolates, never extrapolates); a single sample resolves only at its own stamp;
//   a static frame resolves at any time;
// - a lookup across a parent change between the two samples is reported (tf2 would not
//   interpolate across it).
// Everything tf2 would warn about is collected in `warnings`.

#include <cstdint>
#include <iterator>
#include <map>
#include <string>
#include <vector>

namespace lidarfuse::test {

class Tf2Model {
public:
    static constexpr std::int64_t kCacheTimeNs = 10'000'000'000;

    void add(const std::string& parent, const std::string& child, std::int64_t stamp_ns,
             bool is_static) {
        if (stamp_ns == 0) warnings.push_back(child + ": stamp 0");
        if (parent == child) warnings.push_back(child + ": its own parent");
        auto& cache = frames_[child];
        if (!cache.samples.empty() && cache.is_static != is_static) {
            warnings.push_back(child + ": switched between rt/tf and rt/tf_static");
            cache.samples.clear();
        }
        cache.is_static = is_static;
        if (is_static) {
            cache.samples.clear();
            cache.samples[0] = parent;
            return;
        }
        if (!cache.samples.empty()) {
            const std::int64_t newest = cache.samples.rbegin()->first;
            if (stamp_ns < newest - kCacheTimeNs) {
                warnings.push_back(child + ": TF_OLD_DATA");
                return;
            }
            if (cache.samples.count(stamp_ns)) {
                warnings.push_back(child + ": TF_REPEATED_DATA");
                return;
            }
        }
        cache.samples[stamp_ns] = parent;
    }

    // Whether child's transform to its parent is known at stamp_ns; `why` says why not.
    bool resolves(const std::string& child, std::int64_t stamp_ns, std::string* why) const {
        const auto it = frames_.find(child);
        if (it == frames_.end() || it->second.samples.empty()) {
            *why = "unknown frame";
            return false;
        }
        const auto& cache = it->second;
        if (cache.is_static || cache.samples.count(stamp_ns)) return true;
        const auto after = cache.samples.lower_bound(stamp_ns);
        if (after == cache.samples.end()) {
            *why = "extrapolation into the future";
            return false;
        }
        if (after == cache.samples.begin()) {
            *why = "extrapolation into the past";
            return false;
        }
        if (std::prev(after)->second != after->second) {
            *why = "parent changed between the samples";
            return false;
        }
        return true;
    }

    // The oldest stamp the child's dynamic cache holds (0 when none).
    std::int64_t first_stamp(const std::string& child) const {
        const auto it = frames_.find(child);
        return it == frames_.end() || it->second.samples.empty()
                   ? 0
                   : it->second.samples.begin()->first;
    }

    std::vector<std::string> warnings;

private:
    struct Cache {
        bool is_static = false;
        std::map<std::int64_t, std::string> samples;  // stamp -> parent
    };
    std::map<std::string, Cache> frames_;
};

}  // namespace lidarfuse::test

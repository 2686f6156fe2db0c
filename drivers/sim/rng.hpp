#pragma once
// Counter-based random numbers for the simulator. Every random draw is a pure function of
// (seed, stream keys), so a pixel's noise does not depend on which thread renders it or
// in which order: output is byte-identical for any thread count. The mixer is SplitMix64's
// finaliser (Steele, Lea, Flood 2014), applied in a chain over the keys.

#include <cmath>
#include <cstdint>

namespace lidarfuse::sim {

constexpr std::uint64_t mix64(std::uint64_t z) {
    z += 0x9E3779B97F4A7C15ULL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

// A counter-based generator: the key identifies the stream (e.g. seed, sensor, frame,
// column, row); next() walks a counter inside it.
class CounterRng {
public:
    constexpr explicit CounterRng(std::uint64_t key) : key_(mix64(key)) {}
    constexpr CounterRng(std::uint64_t a, std::uint64_t b) : key_(mix64(mix64(a) ^ b)) {}
    constexpr CounterRng(std::uint64_t a, std::uint64_t b, std::uint64_t c)
        : key_(mix64(mix64(mix64(a) ^ b) ^ c)) {}

    constexpr std::uint64_t next() { return mix64(key_ ^ mix64(++counter_)); }
    // Uniform in [0, 1) with 53 random bits.
    double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
    double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
    // Standard normal by Box-Muller (both uniforms from this stream).
    double normal() {
        const double u1 = 1.0 - uniform();  // (0, 1]
        const double u2 = uniform();
        return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
    }

private:
    std::uint64_t key_;
    std::uint64_t counter_ = 0;
};

}  // namespace lidarfuse::sim

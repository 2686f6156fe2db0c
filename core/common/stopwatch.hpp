#pragma once
// Wall time of a stage on the steady clock, for the timings that results report (seconds
// for the initial registration's stages, milliseconds for a frame's).

#include <chrono>

namespace lidarfuse::core {

class Stopwatch {
public:
    Stopwatch() : start_(Clock::now()) {}
    void restart() { start_ = Clock::now(); }
    double seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
    double milliseconds() const {
        return std::chrono::duration<double, std::milli>(Clock::now() - start_).count();
    }

private:
    using Clock = std::chrono::steady_clock;
    Clock::time_point start_;
};

}  // namespace lidarfuse::core

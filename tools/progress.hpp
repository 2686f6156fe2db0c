#pragma once
// The progress line of the long commands (fuse, sim, calibrate, replay): one line on stderr,
// redrawn in place, saying what is done of how much, how fast, since when and for how much
// longer. Only when stderr is a terminal and --quiet was not given; the `name value unit`
// lines on stdout are never touched, so scripts that read them see no difference.
#include <chrono>
#include <cstdio>
#include <string>

namespace lidarfuse::tools {

class Args;

// stderr is a terminal and the command was not given --quiet.
bool progress_wanted(const Args& args);

// The bytes of the capture a command reads through (a file, or a recording folder's files),
// for its share done; 0 when unknown.
double progress_file_bytes(const std::string& path);

// What one redraw shows. fraction in [0, 1], or negative when the total is unknown (then
// no share and no time left are shown).
struct ProgressState {
    std::string stage;  // e.g. "fusing"; empty: none
    double done = 0;    // in `unit`
    double total = 0;   // in `unit`; 0: unknown (the count stands alone)
    std::string unit;   // e.g. "frames"; empty: no count shown (a stage alone)
    double fraction = -1;
    double elapsed_s = 0;
};

// "fuse: fusing 120/400 frames (30 %), 24.0 frames/s, 0:05 elapsed, 0:12 left"
std::string format_progress(const std::string& command, const ProgressState& state);

class ProgressLine {
public:
    // Draws nothing when `enabled` is false. `out` is stderr but for tests.
    ProgressLine(std::string command, bool enabled, std::FILE* out = stderr);
    ~ProgressLine();
    ProgressLine(const ProgressLine&) = delete;
    ProgressLine& operator=(const ProgressLine&) = delete;

    // Redraws at most every 0.2 s (and on a new stage); elapsed time is filled in here.
    void update(ProgressState state);
    // Clears the line, so what follows on stderr starts on a clean one.
    void finish();

private:
    using Clock = std::chrono::steady_clock;
    std::string command_;
    bool enabled_;
    std::FILE* out_;
    Clock::time_point start_ = Clock::now();
    Clock::time_point last_draw_{};
    std::string last_stage_;
    bool drawn_ = false;
};

}  // namespace lidarfuse::tools

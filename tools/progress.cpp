#include "tools/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include "drivers/pcap/pcap_reader.hpp"
#include "tools/args.hpp"

namespace lidarfuse::tools {

namespace {

// "m:ss", or "h:mm:ss" from an hour on.
std::string clock_text(double seconds) {
    const long long s = std::max(0LL, std::llround(seconds));
    char text[32];
    if (s >= 3600) {
        std::snprintf(text, sizeof text, "%lld:%02lld:%02lld", s / 3600, (s / 60) % 60, s % 60);
    } else {
        std::snprintf(text, sizeof text, "%lld:%02lld", s / 60, s % 60);
    }
    return text;
}

std::string number_text(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.0f", value);
    return text;
}

}  // namespace

bool progress_wanted(const Args& args) {
    return !args.flag("--quiet") && ::isatty(STDERR_FILENO) == 1;
}

double progress_file_bytes(const std::string& path) {
    std::vector<std::filesystem::path> files;
    try {
        files = pcap::capture_files(path);
    } catch (const std::exception&) {
        return 0.0;
    }
    double bytes = 0.0;
    for (const auto& file : files) {
        std::error_code error;
        const auto size = std::filesystem::file_size(file, error);
        if (error) return 0.0;
        bytes += static_cast<double>(size);
    }
    return bytes;
}

std::string format_progress(const std::string& command, const ProgressState& state) {
    std::string line = command + ":";
    if (!state.stage.empty()) line += " " + state.stage;
    if (!state.unit.empty()) {
        line += " " + number_text(state.done);
        if (state.total > 0) line += "/" + number_text(state.total);
        line += " " + state.unit;
    }
    const double fraction = std::min(1.0, state.fraction);
    if (fraction >= 0) line += " (" + number_text(100.0 * fraction) + " %)";
    if (state.elapsed_s > 0 && state.done > 0 && !state.unit.empty()) {
        char rate[48];
        std::snprintf(rate, sizeof rate, ", %.1f %s/s", state.done / state.elapsed_s,
                      state.unit.c_str());
        line += rate;
    }
    line += ", " + clock_text(state.elapsed_s) + " elapsed";
    if (fraction > 0)
        line += ", " + clock_text(state.elapsed_s * (1.0 - fraction) / fraction) + " left";
    return line;
}

ProgressLine::ProgressLine(std::string command, bool enabled, std::FILE* out)
    : command_(std::move(command)), enabled_(enabled), out_(out) {}

ProgressLine::~ProgressLine() { finish(); }

void ProgressLine::update(ProgressState state) {
    if (!enabled_) return;
    const auto now = Clock::now();
    const bool new_stage = state.stage != last_stage_;
    if (drawn_ && !new_stage && now - last_draw_ < std::chrono::milliseconds(200)) return;
    state.elapsed_s = std::chrono::duration<double>(now - start_).count();
    // \r and "erase to the end of the line" (ECMA-48 EL): the new line overwrites the old.
    std::fprintf(out_, "\r%s\x1b[K", format_progress(command_, state).c_str());
    std::fflush(out_);
    last_draw_ = now;
    last_stage_ = state.stage;
    drawn_ = true;
}

void ProgressLine::finish() {
    if (!enabled_ || !drawn_) return;
    std::fprintf(out_, "\r\x1b[K");
    std::fflush(out_);
    drawn_ = false;
}

}  // namespace lidarfuse::tools

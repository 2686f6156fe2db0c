// `lidarfuse SUBCOMMAND ...`: dispatches to the registered subcommands (tools/command.hpp).
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <exception>

#include "drivers/build_info.hpp"
#include "drivers/process_env.hpp"
#include "tools/command.hpp"

namespace lidarfuse::tools {

namespace {
std::vector<Command>& registry() {
    static std::vector<Command> all;
    return all;
}
}  // namespace

bool register_command(Command command) {
    registry().push_back(std::move(command));
    return true;
}

const std::vector<Command>& commands() { return registry(); }

}  // namespace lidarfuse::tools

namespace {

void print_usage(std::FILE* out) {
    auto sorted = lidarfuse::tools::commands();
    std::sort(sorted.begin(), sorted.end(),
              [](const auto& a, const auto& b) { return a.name < b.name; });
    std::fprintf(out,
                 "usage: lidarfuse COMMAND [ARGS...]   (lidarfuse COMMAND --help for details)\n\n");
    for (const auto& command : sorted) {
        std::fprintf(out, "  %-10s %s\n", command.name.c_str(), command.summary.c_str());
    }
}

}  // namespace

int main(int argc, char** argv) {
    lidarfuse::drivers::ensure_passive_openmp(argv);
    lidarfuse::drivers::keep_frame_buffers_in_heap();
    if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
        print_usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? 2 : 0;
    }
    if (!std::strcmp(argv[1], "--version")) {
        std::printf("lidarfuse %s\n", lidarfuse::drivers::version().c_str());
        return 0;
    }
    for (const auto& command : lidarfuse::tools::commands()) {
        if (command.name == argv[1]) {
            try {
                return command.run(argc - 1, argv + 1);
            } catch (const std::exception& error) {
                std::fprintf(stderr, "lidarfuse %s: error: %s\n", argv[1], error.what());
                return 1;
            }
        }
    }
    std::fprintf(stderr, "lidarfuse: unknown command '%s'\n\n", argv[1]);
    print_usage(stderr);
    return 2;
}

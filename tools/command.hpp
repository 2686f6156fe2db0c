#pragma once
// Subcommand registry of the `lidarfuse` command line. Each tools/cmd_*.cpp defines one
// subcommand and registers it with a file-scope LIDARFUSE_REGISTER_COMMAND; main.cpp
// dispatches on argv[1]. Registration happens during static initialisation of this
// executable only (the sources are compiled into it, not into a library).

#include <string>
#include <vector>

namespace lidarfuse::tools {

// argv[0] is the subcommand name; returns the process exit status.
using CommandFn = int (*)(int argc, char** argv);

struct Command {
    std::string name;
    std::string summary;  // one line for `lidarfuse --help`
    CommandFn run;
};

bool register_command(Command command);
const std::vector<Command>& commands();

}  // namespace lidarfuse::tools

#define LIDARFUSE_REGISTER_COMMAND(name, summary, fn) \
    static const bool lidarfuse_registered_##fn =     \
        ::lidarfuse::tools::register_command({name, summary, &fn})

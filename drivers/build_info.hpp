#pragma once
// Version of the lidarfuse build, for `lidarfuse --version`, logs and diagnostics.
#include <string>

namespace lidarfuse::drivers {
std::string version();
}  // namespace lidarfuse::drivers

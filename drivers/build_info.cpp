#include "drivers/build_info.hpp"

namespace lidarfuse::drivers {
std::string version() { return LIDARFUSE_VERSION; }
}  // namespace lidarfuse::drivers

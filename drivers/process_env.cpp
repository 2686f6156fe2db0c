#include "drivers/process_env.hpp"

#include <unistd.h>

#include <cstdlib>

namespace lidarfuse::drivers {

void ensure_passive_openmp(char** argv) {
    if (std::getenv("OMP_WAIT_POLICY") != nullptr) return;
    if (::setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
    ::execv("/proc/self/exe", argv);
    // execv failed (no /proc): carry on with the default policy.
}

}  // namespace lidarfuse::drivers

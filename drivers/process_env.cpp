#include "drivers/process_env.hpp"

#include <malloc.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>

namespace lidarfuse::drivers {

void ensure_passive_openmp(char** argv) {
    if (std::getenv("OMP_WAIT_POLICY") != nullptr) return;
    if (::setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
    ::execv("/proc/self/exe", argv);
    // execv failed (no /proc): carry on with the default policy.
}

void keep_frame_buffers_in_heap() {
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    if (tunables != nullptr && std::strstr(tunables, "glibc.malloc.") != nullptr) return;
    constexpr int kMiB = 1 << 20;
    ::mallopt(M_MMAP_THRESHOLD, 32 * kMiB);
    ::mallopt(M_TRIM_THRESHOLD, 64 * kMiB);
}

}  // namespace lidarfuse::drivers

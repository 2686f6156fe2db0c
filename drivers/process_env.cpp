#include "drivers/process_env.hpp"

#include <limits.h>
#include <malloc.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>

namespace lidarfuse::drivers {

void ensure_passive_openmp(char** argv) {
    if (std::getenv("OMP_WAIT_POLICY") != nullptr) return;
    if (::setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
    // The program's own path rather than /proc/self/exe: the kernel names a process after
    // the last component of the path it was started from, and `ps`, `top` and `pidof
    // lidarfused` should find "lidarfused", not "exe".
    char path[PATH_MAX];
    const ssize_t length = ::readlink("/proc/self/exe", path, sizeof path - 1);
    if (length > 0) {
        path[length] = '\0';
        ::execv(path, argv);
    }
    // The file is gone (replaced by an upgrade since the start) or no /proc: the link still
    // reaches the running program; failing that, carry on with the default policy.
    ::execv("/proc/self/exe", argv);
}

void keep_frame_buffers_in_heap() {
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    if (tunables != nullptr && std::strstr(tunables, "glibc.malloc.") != nullptr) return;
    constexpr int kMiB = 1 << 20;
    ::mallopt(M_MMAP_THRESHOLD, 32 * kMiB);
    ::mallopt(M_TRIM_THRESHOLD, 64 * kMiB);
    ::mallopt(M_ARENA_MAX, kMallocArenas);
}

}  // namespace lidarfuse::drivers

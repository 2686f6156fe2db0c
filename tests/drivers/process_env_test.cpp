#include "drivers/process_env.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <functional>

namespace lidarfuse::drivers {
namespace {

long minor_faults() {
    rusage usage{};
    ::getrusage(RUSAGE_SELF, &usage);
    return usage.ru_minflt;
}

// A frame's buffer made and freed five times (24 MiB); exits 0 when the last four together
// faulted in fewer than a tenth of the pages the first did (the buffer was kept and
// reused), 1 otherwise. glibc's own dynamic thresholds map the first, then serve the second
// from a heap that is still cold, so they fault twice.
[[noreturn]] void allocate_frames_and_exit() {
    constexpr std::size_t kBytes = std::size_t{24} << 20;
    long first = 0, later = 0;
    for (int frame = 0; frame < 5; ++frame) {
        const long before = minor_faults();
        auto* buffer = static_cast<volatile char*>(std::malloc(kBytes));
        if (buffer == nullptr) ::_exit(2);
        for (std::size_t i = 0; i < kBytes; i += 4096) buffer[i] = 1;  // every page touched
        std::free(const_cast<char*>(buffer));
        (frame == 0 ? first : later) += minor_faults() - before;
    }
    ::_exit(first > 1000 && later < first / 10 ? 0 : 1);
}

// The exit code of allocate_frames_and_exit() in a child process after `setup`, so that
// the allocator settings never reach this test process.
int frames_in_child(const std::function<void()>& setup) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        setup();
        allocate_frames_and_exit();
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(ProcessEnv, AFreedFrameBufferIsReusedWithoutFaultingItsPagesAgain) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    GTEST_SKIP() << "the sanitizers' allocators ignore mallopt; the release build checks it";
#endif
    EXPECT_EQ(frames_in_child([] { keep_frame_buffers_in_heap(); }), 0);
    // Without the call glibc maps and unmaps such a buffer on every frame.
    EXPECT_EQ(frames_in_child([] {}), 1);
    // A user's own malloc tunables win: the call leaves glibc's settings alone.
    EXPECT_EQ(frames_in_child([] {
                  ::setenv("GLIBC_TUNABLES", "glibc.malloc.check=0", 1);
                  keep_frame_buffers_in_heap();
              }),
              1);
}

}  // namespace
}  // namespace lidarfuse::drivers

/* LD_PRELOAD shim for tests/reliability/host_clock_jump_test.cpp: makes the process see
 * the host's wall clock jump, without CAP_SYS_TIME and without touching the real clock.
 *
 * clock_gettime() for CLOCK_REALTIME, CLOCK_REALTIME_COARSE and CLOCK_TAI, gettimeofday()
 * and time() return the true time plus an offset the test sets at any moment through
 * lidarfuse_realtime_shift_set_ns() (found with dlsym(RTLD_DEFAULT, ...)); every other
 * clock (CLOCK_MONOTONIC, CLOCK_BOOTTIME, CPU clocks) is passed through untouched.
 * std::chrono::system_clock and steady_clock (libstdc++) and glibc's own callers reach
 * clock_gettime through the PLT, so the preloaded definition is the one they call; the
 * test checks that it took effect. The kernel's clock is not changed: a wait given an
 * absolute CLOCK_REALTIME deadline computed from a shifted time would sleep the offset
 * too long (or not at all), which is what a real jump does to such code.
 *
 * Real clocks: the next definition in the lookup order (libc, or a sanitizer's
 * interceptor), else the raw system call. Thread safe (C11 atomics). Built without the
 * project's sanitizer flags: it is preloaded ahead of their runtimes. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdatomic.h>
#include <stdint.h>
#include <sys/syscall.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

typedef int (*clock_gettime_fn)(clockid_t, struct timespec*);

static _Atomic int64_t offset_ns;
static _Atomic uint64_t shifted_reads;
static _Atomic(clock_gettime_fn) next_clock_gettime;

static int real_clock_gettime(clockid_t id, struct timespec* ts) {
    clock_gettime_fn next = atomic_load(&next_clock_gettime);
    if (!next) {
        next = (clock_gettime_fn)dlsym(RTLD_NEXT, "clock_gettime");
        if (next) atomic_store(&next_clock_gettime, next);
    }
    if (next) return next(id, ts);
    return (int)syscall(SYS_clock_gettime, id, ts);
}

static int is_wall_clock(clockid_t id) {
    return id == CLOCK_REALTIME || id == CLOCK_REALTIME_COARSE || id == CLOCK_TAI;
}

static void shift(struct timespec* ts) {
    const int64_t ns = (int64_t)ts->tv_sec * 1000000000 + ts->tv_nsec + atomic_load(&offset_ns);
    ts->tv_sec = (time_t)(ns / 1000000000);
    ts->tv_nsec = (long)(ns % 1000000000);
    if (ts->tv_nsec < 0) {
        ts->tv_nsec += 1000000000;
        ts->tv_sec -= 1;
    }
    atomic_fetch_add(&shifted_reads, 1);
}

int clock_gettime(clockid_t id, struct timespec* ts) {
    const int rc = real_clock_gettime(id, ts);
    if (rc == 0 && is_wall_clock(id)) shift(ts); /* ts: nonnull in glibc's declaration */
    return rc;
}

int gettimeofday(struct timeval* restrict tv, void* restrict tz) {
    (void)tz;
    struct timespec ts;
    if (clock_gettime(CLOCK_REALTIME, &ts) != 0) return -1;
    tv->tv_sec = ts.tv_sec; /* tv: nonnull in glibc's declaration */
    tv->tv_usec = (suseconds_t)(ts.tv_nsec / 1000);
    return 0;
}

time_t time(time_t* out) {
    struct timespec ts;
    if (clock_gettime(CLOCK_REALTIME, &ts) != 0) return (time_t)-1;
    if (out) *out = ts.tv_sec;
    return ts.tv_sec;
}

void lidarfuse_realtime_shift_set_ns(int64_t ns) { atomic_store(&offset_ns, ns); }
int64_t lidarfuse_realtime_shift_ns(void) { return atomic_load(&offset_ns); }
/* Wall-clock reads that were shifted since the process started. */
uint64_t lidarfuse_realtime_shift_reads(void) { return atomic_load(&shifted_reads); }

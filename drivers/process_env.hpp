#pragma once
// Process start-up settings that must be in place before any library reads them.
//
// glibc's allocator serves a buffer of more than 128 kB (growing with the largest one freed,
// up to 32 MB) by mmap and returns it to the kernel on free. A frame's buffers (scans of 1.5
// MB, a fused cloud of several MB, its DDS message) are made in one thread and freed in
// another a frame later, so their pages were faulted in again on every frame: thousands of
// faults per second, each costly on a paravirtualised machine. The daemon hands its own
// buffers back (daemon/buffer_pool.hpp), but Cyclone's serialisation buffer of a 5 MB cloud
// is out of its reach. keep_frame_buffers_in_heap() sets both thresholds, from the start,
// to the largest values glibc's own dynamic thresholds reach (bench/BENCHMARK.md, "Frame
// buffers handed back to their producer": RSS steadier over 30 minutes, not higher).
// It also caps the allocator at kMallocArenas arenas (heaps) instead of glibc's 8 per core:
// each thread that allocates gets an arena of its own up to that cap, and memory freed in one
// arena serves only the threads of that arena, so with a dozen threads (receivers, fusion and its
// team, the initial registration's team, the output, Cyclone's) each arena kept its own tens
// of MB of freed frame buffers and registration scratch (bench/BENCHMARK.md, "8 sensors in
// 250 MiB").
//
// OpenMP threads spin while they wait by default (OMP_WAIT_POLICY=active). On a 2-core
// station that spinning competes with the receiver threads and made 2-thread G-ICP 30x
// slower on a loaded machine (core/registration/gicp.hpp). libgomp reads the variable once, when it
// is loaded, so setting it from main() is too late: ensure_passive_openmp() re-executes the program
// with OMP_WAIT_POLICY=passive unless the user set the variable already.

namespace lidarfuse::drivers {

// Call first thing in main(). Returns only when no re-exec was needed or it failed (then
// the program simply runs with the default policy).
void ensure_passive_openmp(char** argv);

// Buffers up to 32 MiB from the heap, up to 64 MiB of freed heap kept mapped, at most
// kMallocArenas arenas. Call early in main(), before any thread starts. Leaves glibc's settings
// alone when the user set any `glibc.malloc.` tunable in GLIBC_TUNABLES.
inline constexpr int kMallocArenas = 2;
void keep_frame_buffers_in_heap();

}  // namespace lidarfuse::drivers

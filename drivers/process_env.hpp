#pragma once
// Process start-up settings that must be in place before any library reads them.
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

}  // namespace lidarfuse::drivers

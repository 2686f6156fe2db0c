// libFuzzer harness: a PLY file's bytes -> io::read_ply (header, ascii / binary little and
// big endian, elements and list properties before and after vertex). Checks:
// fuzz/cloud_checks.hpp.
#include <cstddef>
#include <cstdint>

#include "drivers/io/cloud_file.hpp"
#include "fuzz/cloud_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    lidarfuse::fuzz::check_cloud_reader(data, size, "fuzz.ply",
                                        [](const std::string& bytes, const char* name) {
                                            return lidarfuse::io::read_ply(bytes, name);
                                        });
    return 0;
}

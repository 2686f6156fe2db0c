// libFuzzer harness: a PCD file's bytes -> io::read_pcd (header, DATA ascii / binary /
// binary_compressed through liblzf). Checks: fuzz/cloud_checks.hpp.
#include <cstddef>
#include <cstdint>

#include "drivers/io/cloud_file.hpp"
#include "fuzz/cloud_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    lidarfuse::fuzz::check_cloud_reader(data, size, "fuzz.pcd",
                                        [](const std::string& bytes, const char* name) {
                                            return lidarfuse::io::read_pcd(bytes, name);
                                        });
    return 0;
}

// Explicit instantiations of destagger/restagger for the pixel types of a LidarScan, so
// callers that only need these do not re-instantiate the templates.

#include "drivers/ouster/destagger.hpp"

#include <cstdint>

namespace lidarfuse::ouster {

template void destagger<std::uint8_t>(const std::uint8_t*, int, int, const std::vector<int>&,
                                      std::uint8_t*);
template void destagger<std::uint16_t>(const std::uint16_t*, int, int, const std::vector<int>&,
                                       std::uint16_t*);
template void destagger<std::uint32_t>(const std::uint32_t*, int, int, const std::vector<int>&,
                                       std::uint32_t*);
template void destagger<float>(const float*, int, int, const std::vector<int>&, float*);
template void restagger<std::uint8_t>(const std::uint8_t*, int, int, const std::vector<int>&,
                                      std::uint8_t*);
template void restagger<std::uint16_t>(const std::uint16_t*, int, int, const std::vector<int>&,
                                       std::uint16_t*);
template void restagger<std::uint32_t>(const std::uint32_t*, int, int, const std::vector<int>&,
                                       std::uint32_t*);
template void restagger<float>(const float*, int, int, const std::vector<int>&, float*);

}  // namespace lidarfuse::ouster

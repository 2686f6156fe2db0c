#pragma once
// md5 of a byte range as lower-case hex (OpenSSL EVP), for Ouster's digest convention.
// Lives in tools/ so that the drivers library does not depend on libcrypto.

#include <cstddef>
#include <string>

namespace lidarfuse::tools {

// Throws std::runtime_error if OpenSSL fails (it does not for md5 in practice).
std::string md5_hex(const void* data, std::size_t size);

}  // namespace lidarfuse::tools

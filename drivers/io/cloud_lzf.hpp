#pragma once
// LZF (liblzf) as PCD's DATA binary_compressed uses it: after the header, uint32
// compressed size, uint32 uncompressed size (little endian), then the LZF stream, which
// decompresses to the points in struct-of-arrays order (every value of the first field,
// then of the second, ...).

#include <cstddef>
#include <cstdint>
#include <string>

namespace lidarfuse::io {

// An LZF stream expands at most 88-fold: its longest back reference is 3 bytes for 264.
constexpr std::uint64_t kLzfMaxExpansion = 88;

// Decompresses `size` bytes that must give exactly `expected_size` bytes; an error naming
// `name` otherwise (corrupt stream, or one that decodes to more or fewer bytes).
std::string lzf_decompress_exact(const char* data, std::size_t size, std::size_t expected_size,
                                 const std::string& name);

// An LZF stream of `data`: liblzf's when it is shorter than the data, else the data as LZF
// literal runs (1 control byte per 32 bytes). PCD has no "stored uncompressed" flag, so the
// fallback keeps incompressible clouds (random test data, noise) writable.
std::string lzf_compress_for_pcd(const std::string& data);

// The fallback on its own (for tests): every byte as a literal.
std::string lzf_literal_runs(const std::string& data);

}  // namespace lidarfuse::io

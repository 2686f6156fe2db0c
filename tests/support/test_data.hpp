#pragma once
// Helpers shared by the tests: where the sample captures live, temporary folders, md5.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace lidarfuse::test {

// The shared data folder: $LIDARFUSE_DATA_DIR, else the CMake cache value
// LIDARFUSE_DATA_DIR (default ../shared/data beside the checkout). Empty when absent.
std::optional<std::filesystem::path> data_dir();

// The checkout the tests were built from (config/, systemd/ ...).
std::filesystem::path source_dir();

// Path of an Ouster sample file (data_dir()/ouster/NAME), or nullopt when the data
// folder or the file is missing. Use through LIDARFUSE_REQUIRE_OUSTER_FILE.
std::optional<std::filesystem::path> ouster_file(const std::string& name);

// A fresh empty folder under the system temp dir, removed by the destructor.
class TempDir {
public:
    explicit TempDir(const std::string& tag = "lidarfuse");
    ~TempDir();
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

// The first of kPortBlockSize loopback UDP ports reserved for this test process: no other
// process that asks (tests run in parallel, and two checkouts' suites may share a machine)
// gets them while it lives. Below Linux's ephemeral range (32768..), so no socket of DDS
// or an HTTP client takes one by chance. Each test file places its sensors at offsets of
// its own inside the block. Throws when every block is taken.
constexpr int kPortBlockSize = 64;
std::uint16_t port_block();
// Which block that is (0..197): unique among the test processes alive, like the block, so
// it also names a DDS domain of this process's own.
int port_block_index();

// Lower-case hex md5 of a byte range (OpenSSL EVP).
std::string md5_hex(const void* data, std::size_t size);

// Absolute paths of the built executables.
std::string tool_path();    // lidarfuse
std::string daemon_path();  // lidarfused
// Where tests/foxglove/install.sh puts the live view's Node client (Foxglove's npm packages)
// in this build folder.
std::filesystem::path foxglove_client_dir();

// A file's whole content (bytes as they are); empty when it cannot be read.
std::string file_text(const std::filesystem::path& path);

// Runs a shell command, captures stdout+stderr into `output`, returns the exit status.
int run_command(const std::string& command, std::string* output);

// The value of a `name value unit` line in a command's output (the benchmark and tool
// convention), or nullopt when no line starts with `name `. (No std::regex: GCC 12 warns
// inside it under the sanitizers, and warnings are errors.)
std::optional<double> figure(const std::string& output, const std::string& name);

// The text after `prefix` up to the end of its line, at the first occurrence.
std::optional<std::string> line_after(const std::string& output, const std::string& prefix);

}  // namespace lidarfuse::test

// Skips the current test, with a visible reason, when a sample file is not available.
#define LIDARFUSE_REQUIRE_OUSTER_FILE(var, name)                                         \
    const auto var##_opt = ::lidarfuse::test::ouster_file(name);                         \
    if (!var##_opt) {                                                                    \
        GTEST_SKIP() << "sample data " << (name)                                         \
                     << " not found (set LIDARFUSE_DATA_DIR to the shared/data folder)"; \
    }                                                                                    \
    const std::filesystem::path var = *var##_opt

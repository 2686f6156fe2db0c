#include "tests/support/test_data.hpp"

#include <fcntl.h>
#include <openssl/evp.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace lidarfuse::test {

std::optional<std::filesystem::path> data_dir() {
    const char* env = std::getenv("LIDARFUSE_DATA_DIR");
    std::filesystem::path dir = (env && *env) ? env : LIDARFUSE_DEFAULT_DATA_DIR;
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) return std::nullopt;
    return dir;
}

std::filesystem::path source_dir() { return LIDARFUSE_SOURCE_DIR; }

std::optional<std::filesystem::path> ouster_file(const std::string& name) {
    const auto dir = data_dir();
    if (!dir) return std::nullopt;
    auto file = *dir / "ouster" / name;
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) return std::nullopt;
    return file;
}

TempDir::TempDir(const std::string& tag) {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            (tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
}

std::string md5_hex(const void* data, std::size_t size) {
    std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
    unsigned int length = 0;
    if (EVP_Digest(data, size, digest.data(), &length, EVP_md5(), nullptr) != 1) {
        throw std::runtime_error("EVP_Digest(md5) failed");
    }
    static const char* const kHex = "0123456789abcdef";
    std::string out;
    for (unsigned int i = 0; i < length; ++i) {
        out += kHex[digest[i] >> 4];
        out += kHex[digest[i] & 0xF];
    }
    return out;
}

std::string tool_path() { return LIDARFUSE_TOOL_PATH; }
std::string daemon_path() { return LIDARFUSED_PATH; }
std::filesystem::path foxglove_client_dir() { return LIDARFUSE_FOXGLOVE_CLIENT_DIR; }

std::string file_text(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

int run_command(const std::string& command, std::string* output) {
    FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
    if (!pipe) return -1;
    std::array<char, 4096> buffer{};
    std::size_t n = 0;
    while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) {
        if (output) output->append(buffer.data(), n);
    }
    const int status = ::pclose(pipe);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::optional<std::string> line_after(const std::string& output, const std::string& prefix) {
    const auto at = output.find(prefix);
    if (at == std::string::npos) return std::nullopt;
    const auto begin = at + prefix.size();
    const auto end = output.find('\n', begin);
    return output.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
}

std::optional<double> figure(const std::string& output, const std::string& name) {
    std::size_t at = 0;
    while ((at = output.find(name + " ", at)) != std::string::npos) {
        if (at == 0 || output[at - 1] == '\n') {
            const char* begin = output.c_str() + at + name.size() + 1;
            char* end = nullptr;
            const double value = std::strtod(begin, &end);
            if (end != begin) return value;
        }
        at += name.size();
    }
    return std::nullopt;
}

namespace {

constexpr int kFirstBlockPort = 20000;
constexpr int kBlocks = (32768 - kFirstBlockPort) / kPortBlockSize;

// A block is taken while a process holds an exclusive flock on its lock file; the kernel
// drops the lock when the process ends, however it ends.
std::uint16_t reserve_port_block() {
    const std::filesystem::path folder =
        std::filesystem::temp_directory_path() / "lidarfuse-test-ports";
    std::error_code error;
    std::filesystem::create_directories(folder, error);
    const int first = static_cast<int>(::getpid() % kBlocks);
    for (int i = 0; i < kBlocks; ++i) {
        const int block = (first + i) % kBlocks;
        const std::string file = (folder / ("block-" + std::to_string(block) + ".lock")).string();
        const int fd = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
        if (fd < 0) continue;
        if (::flock(fd, LOCK_EX | LOCK_NB) == 0) {  // kept open: held until the process ends
            return static_cast<std::uint16_t>(kFirstBlockPort + block * kPortBlockSize);
        }
        ::close(fd);
    }
    throw std::runtime_error("port_block: every block of test ports in " + folder.string() +
                             " is held by another process");
}

}  // namespace

std::uint16_t port_block() {
    static const std::uint16_t kBase = reserve_port_block();
    return kBase;
}

int port_block_index() { return (port_block() - kFirstBlockPort) / kPortBlockSize; }

}  // namespace lidarfuse::test

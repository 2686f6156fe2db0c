#include "bench/foxglove_bench_client.hpp"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <thread>

namespace lidarfuse::bench {

namespace fs = std::filesystem;

std::uint16_t foxglove_port_in_log(const fs::path& log) {
    std::ifstream in(log);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto at = text.find("live view on ws://");
    if (at == std::string::npos) return 0;
    const auto colon = text.find(':', at + 18);
    return colon == std::string::npos
               ? 0
               : static_cast<std::uint16_t>(std::stoi(text.substr(colon + 1)));
}

bool FoxgloveBenchClient::start(std::uint16_t port, const fs::path& out) {
    const fs::path modules = fs::path(LIDARFUSE_FOXGLOVE_CLIENT_DIR) / "node_modules";
    if (!fs::exists(modules / "@foxglove" / "ws-protocol")) {
        std::fprintf(stderr,
                     "daemon_latency_bench: no Foxglove client in %s: run "
                     "tests/foxglove/install.sh <build folder>\n",
                     modules.c_str());
        return false;
    }
    out_ = out;
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ == 0) {
        ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // never outlives the bench
        if (::getppid() != parent) ::_exit(1);
        std::freopen((out.string() + ".log").c_str(), "w", stderr);
        std::freopen((out.string() + ".log").c_str(), "a", stdout);
        ::setenv("NODE_PATH", modules.c_str(), 1);
        const std::string script = std::string(LIDARFUSE_SOURCE_DIR) + "/tests/foxglove/client.cjs";
        const std::string url = "ws://127.0.0.1:" + std::to_string(port);
        ::execlp("node", "node", script.c_str(), url.c_str(), "count", out.c_str(), "3600",
                 nullptr);
        ::_exit(127);
    }
    const fs::path ready = out.string() + ".ready";
    for (int i = 0; i < 6000 && !fs::exists(ready); ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (fs::exists(ready)) return true;
    std::fprintf(stderr, "daemon_latency_bench: the Foxglove client did not subscribe (%s.log)\n",
                 out.c_str());
    return false;
}

FoxgloveCounts FoxgloveBenchClient::stop() {
    FoxgloveCounts counts;
    if (pid_ <= 0) return counts;
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
    pid_ = 0;
    std::ifstream in(out_);
    const auto seen = nlohmann::json::parse(in, nullptr, false);
    if (seen.is_discarded()) return counts;
    counts.messages = seen.value("messages", 0L);
    for (const auto& [topic, numbers] : seen["counted"].items()) {
        if (topic.size() < 7 || topic.compare(topic.size() - 7, 7, "/points") != 0) continue;
        counts.clouds = numbers[0].get<long>();
        counts.cloud_mib = numbers[1].get<double>() / (1024.0 * 1024.0);
    }
    return counts;
}

FoxgloveBenchClient::~FoxgloveBenchClient() { stop(); }

}  // namespace lidarfuse::bench

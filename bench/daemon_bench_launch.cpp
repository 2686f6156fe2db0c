#include "bench/daemon_bench_launch.hpp"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace lidarfuse::bench {

namespace fs = std::filesystem;

std::string built_daemon_path() {
    return (fs::path(LIDARFUSE_TOOL_PATH).parent_path().parent_path() / "daemon" / "lidarfused")
        .string();
}

pid_t start_daemon(const std::string& executable, const fs::path& config, const fs::path& log,
                   const std::string& cyclone_uri) {
    const pid_t bench_pid = ::getpid();
    const pid_t pid = ::fork();
    if (pid != 0) return pid;
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != bench_pid) ::_exit(1);  // the bench died before prctl took effect
    std::freopen(log.c_str(), "w", stderr);
    std::freopen(log.c_str(), "a", stdout);
    set_cyclone_uri(cyclone_uri);
    ::execl(executable.c_str(), "lidarfused", "--config", config.c_str(), nullptr);
    ::_exit(127);
}

bool stop_daemon(pid_t pid) {
    ::kill(pid, SIGTERM);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

void set_cyclone_uri(const std::string& uri) {
    if (uri.empty())
        ::unsetenv("CYCLONEDDS_URI");
    else
        ::setenv("CYCLONEDDS_URI", uri.c_str(), 1);
}

std::string cyclone_uri(const std::string& choice) {
    if (choice == "default") return "";
    if (choice != "bench") return "file://" + fs::absolute(choice).string();
    return "<General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
           "<MaxMessageSize>65500B</MaxMessageSize><FragmentSize>64000B</FragmentSize></General>"
           "<Internal><Watermarks><WhcHigh>16MiB</WhcHigh></Watermarks></Internal>"
           "<Tracing><Verbosity>severe</Verbosity></Tracing>";
}

double process_cpu_s() {
    timespec ts{};
    ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double children_cpu_s() {
    rusage usage{};
    ::getrusage(RUSAGE_CHILDREN, &usage);
    const auto seconds = [](const timeval& t) {
        return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
    };
    return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

double percentile(std::vector<double> v, double p) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const std::size_t i = std::min(
        v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5));
    return v[i];
}

}  // namespace lidarfuse::bench

// Simulator throughput: 4 OS1-64 at 1024x20 in the curve scene with traffic and sway.
//   sim_bench [SECONDS=10] [THREADS=2] [SCENARIO=curve]
// Prints rays per second (wall clock and per CPU second, since this machine's cores are
// shared) and the ratio to real time, rendering into a counting sink (no file I/O) and
// then again into a pcap file with IPv4 fragmentation (the full `lidarfuse sim` path).
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "drivers/sim/sim_outputs.hpp"
#include "drivers/sim/simulator.hpp"

namespace {

double cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
           1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

class CountSink : public lidarfuse::sim::DatagramSink {
public:
    void write(const lidarfuse::sim::SimDatagram& d) override { bytes += d.payload.size(); }
    std::size_t bytes = 0;
};

void report(const char* tag, const lidarfuse::sim::SimParams& p, double rays, double wall_s,
            double cpu_s) {
    const double rays_per_sim_s = rays / p.seconds;
    std::printf("sim_%s_rays %.0f rays\n", tag, rays);
    std::printf("sim_%s_rays_per_s %.0f rays/s\n", tag, rays / wall_s);
    std::printf("sim_%s_rays_per_cpu_s %.0f rays/cpu-s\n", tag, rays / cpu_s);
    std::printf("sim_%s_realtime_ratio %.2f x\n", tag, p.seconds / wall_s);
    // What the run would reach with `threads` cores to itself (CPU time spread evenly).
    std::printf("sim_%s_realtime_ratio_if_%d_cores_free %.2f x\n", tag, p.threads,
                p.threads * (rays / cpu_s) / rays_per_sim_s);
}

}  // namespace

int main(int argc, char** argv) {
    using namespace lidarfuse::sim;
    SimParams p;
    p.seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
    p.threads = argc > 2 ? std::atoi(argv[2]) : 2;
    p.scenario = *scenario_from_string(argc > 3 ? argv[3] : "curve");
    p.sensors = 4;
    p.columns_per_frame = 1024;
    p.frames_per_second = 20;
    {
        const double c0 = cpu_seconds();
        const auto w0 = std::chrono::steady_clock::now();
        Simulator sim(p);
        CountSink sink;
        const SimStats s = sim.run(sink);
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
        report("render", p, static_cast<double>(s.rays), wall, cpu_seconds() - c0);
        std::printf("sim_render_returns_share %.3f share\n",
                    static_cast<double>(s.returns) / static_cast<double>(s.rays));
    }
    {
        const auto dir = std::filesystem::temp_directory_path() / "lidarfuse_sim_bench";
        const double c0 = cpu_seconds();
        const auto w0 = std::chrono::steady_clock::now();
        Simulator sim(p);
        const SimStats s = write_simulation(sim, dir, {});
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
        report("pcap", p, static_cast<double>(s.rays), wall, cpu_seconds() - c0);
        std::printf("sim_pcap_bytes %.0f bytes\n",
                    static_cast<double>(std::filesystem::file_size(dir / "capture.pcap")));
        std::filesystem::remove_all(dir);
    }
    return 0;
}

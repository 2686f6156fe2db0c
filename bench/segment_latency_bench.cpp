// A segment daemon's cost and latency as the number of stations grows (issue 20), on one
// machine: this process plays K stations, publishing each one's recorded fused clouds
// (`lidarfuse fuse ... --world road --save-cloud`) at 20 Hz on rt/station<j>/points, as
// the station daemons would, and subscribes to the segment lidarfused's cloud. The stations'
// own work (their sensors' packets to their clouds) is not here: it runs on each station's
// computer and is daemon_latency_bench's figure. Prints `name value unit` lines:
//   the bytes of one station cloud on the wire (the PointCloud2 message) and per second
//   the segment's latency from the publication of a frame's last station cloud to its
//   segment cloud arriving here: median and p99, over the whole run and the steady run
//   (from kSettleS after the first segment cloud)
//   frames fused, predicted, dropped; the initial registration's time; which stations were
//     registered (the segment's extrinsics.yaml)
//   the daemon's CPU by stage (% of one core) and the bench's own, the peak RSS
//
// Usage: segment_latency_bench CASE STATIONS SECONDS [--thin M] [--daemon PATH] [--keep 1]
//   CASE: a folder with F<j>/fused_<k>.ply and F<j>/poses.csv for j < STATIONS, frames
//   FIRST..LAST (the clouds F0 holds), played in a loop (bench/segment_latency_run.sh
//   makes it). --thin M: each cloud thinned to M voxels first, as a station's
//   points_voxel topic carries it (output.dds.points_voxel_size_m). --keep 1: leave the
//   daemon's folder (config, log, outputs).
#include <dds/dds.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "bench/daemon_bench_launch.hpp"
#include "bench/daemon_process_usage.hpp"
#include "bench/dds_bench_reader.hpp"
#include "core/pipeline/fused_cloud_voxels.hpp"
#include "daemon/dds_messages.hpp"
#include "daemon/sensor_ingest.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/io/fused_cloud_file.hpp"

namespace {

using namespace lidarfuse;
namespace fs = std::filesystem;

constexpr double kSettleS = 2.0;                // as daemon_latency_bench's steady run
constexpr std::int64_t kPeriodNs = 50'000'000;  // 20 Hz

// The frames station 0's folder holds, in order.
std::vector<std::int64_t> recorded_frames(const fs::path& dir) {
    std::vector<std::int64_t> frames;
    for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("fused_", 0) == 0 && entry.path().extension() == ".ply")
            frames.push_back(std::stoll(name.substr(6)));
    }
    std::sort(frames.begin(), frames.end());
    return frames;
}

// Every recorded cloud of station j, thinned when thin_m > 0.
std::vector<core::FusedCloud> station_clouds(const fs::path& dir,
                                             const std::vector<std::int64_t>& frames,
                                             double thin_m) {
    std::vector<core::FusedCloud> clouds;
    core::FusedCloudVoxels voxels;
    for (const std::int64_t k : frames) {
        core::FusedCloud c =
            io::read_fused_cloud_ply(dir / ("fused_" + std::to_string(k) + ".ply"));
        if (thin_m > 0) {
            core::FusedCloud thinned;
            voxels.downsample(c, thin_m, &thinned);
            c = std::move(thinned);
        }
        clouds.push_back(std::move(c));
    }
    return clouds;
}

void write_config(const fs::path& file, const fs::path& out_dir, int stations, int domain) {
    std::ofstream config(file);
    config << "station: bench\nroot: station0\nsensors:\n";
    for (int j = 0; j < stations; ++j) {
        config << "  - {name: station" << j << ", source: {dds: {topic: rt/station" << j
               << "/points, domain_id: " << domain << "}}}\n";
    }
    config << "world: {frame: sensor}\nregistration: {initial_method: stations}\n"
           << "output:\n  directory: " << out_dir.string() << "\n  dds: {domain_id: " << domain
           << ", diagnostics_period_ms: 500}\n";
}

// One writer per station topic (reliable, the last 4 clouds kept for a late reader).
class StationWriters {
public:
    StationWriters(int domain, int stations)
        : participant_(
              dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr)) {
        dds_qos_t* qos = dds_create_qos();
        dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
        dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 4);
        for (int j = 0; j < stations; ++j) {
            const std::string name = "rt/station" + std::to_string(j) + "/points";
            const dds_entity_t topic =
                dds_create_topic(participant_, &sensor_msgs_msg_dds__PointCloud2__desc,
                                 name.c_str(), nullptr, nullptr);
            writers_.push_back(dds_create_writer(participant_, topic, qos, nullptr));
            // Each builder's message points into the builder: they must not move.
            builders_.push_back(std::make_unique<daemon::FrameMessageBuilder>(
                daemon::StationFrames{"station" + std::to_string(j),
                                      "station" + std::to_string(j) + "/fused",
                                      {"x"},
                                      0}));
        }
        dds_delete_qos(qos);
    }
    ~StationWriters() { dds_delete(participant_); }
    bool ok() const {
        return participant_ > 0 &&
               std::all_of(writers_.begin(), writers_.end(), [](dds_entity_t w) { return w > 0; });
    }
    // The bytes of the message's point data, which is all but its header and field list.
    std::size_t write(int j, const core::FusedCloud& cloud, std::int64_t stamp_ns) {
        daemon::FrameStamps stamps;
        stamps.frame_ns = stamp_ns;
        const auto& m = builders_[static_cast<std::size_t>(j)]->cloud(cloud, stamps);
        if (dds_write(writers_[static_cast<std::size_t>(j)], &m) != DDS_RETCODE_OK) return 0;
        return m.data._length;
    }

private:
    dds_entity_t participant_;
    std::vector<dds_entity_t> writers_;
    std::vector<std::unique_ptr<daemon::FrameMessageBuilder>> builders_;
};

struct Published {
    std::map<std::int64_t, std::int64_t> at_ns;  // by stamp: monotonic time of the write
    double bytes = 0;
    std::size_t clouds = 0;
};

// Every station's cloud of each 50 ms tick, stamped with the tick's wall-clock time plus
// 1 ms per station (scans of different stations are never exactly simultaneous).
std::vector<Published> play(const std::vector<std::vector<core::FusedCloud>>& clouds,
                            StationWriters* writers, double seconds) {
    std::vector<Published> published(clouds.size());
    const std::int64_t start = bench::monotonic_ns();
    const auto ticks = static_cast<std::int64_t>(seconds * 1e9 / kPeriodNs);
    for (std::int64_t t = 0; t < ticks; ++t) {
        const std::int64_t due = start + t * kPeriodNs;
        while (bench::monotonic_ns() < due)
            std::this_thread::sleep_for(std::chrono::microseconds(200));
        const std::int64_t stamp = daemon::realtime_ns();
        for (std::size_t j = 0; j < clouds.size(); ++j) {
            const auto& c = clouds[j][static_cast<std::size_t>(t) % clouds[j].size()];
            const std::int64_t s = stamp + static_cast<std::int64_t>(j) * 1'000'000;
            const std::size_t bytes = writers->write(static_cast<int>(j), c, s);
            if (bytes == 0) continue;
            published[j].at_ns[s] = bench::monotonic_ns();
            published[j].bytes += static_cast<double>(bytes);
            ++published[j].clouds;
        }
    }
    return published;
}

// Latency of every segment cloud: its arrival - the write of the last station cloud in it.
std::pair<std::vector<double>, std::vector<double>> latencies(
    const bench::Received& received, const std::vector<Published>& published) {
    std::vector<double> all, steady;
    std::int64_t first = 0;
    for (const auto& [stamp, arrival] : received.cloud_arrival_ns)
        first = first == 0 ? arrival : std::min(first, arrival);
    for (const auto& [stamp, arrival] : received.cloud_arrival_ns) {
        const auto members = received.members.find(stamp);
        if (members == received.members.end()) continue;
        std::int64_t last = 0;
        for (std::size_t j = 0; j < members->second.size() && j < published.size(); ++j) {
            const auto it = published[j].at_ns.find(members->second[j]);
            if (it != published[j].at_ns.end()) last = std::max(last, it->second);
        }
        if (last == 0) continue;
        all.push_back(static_cast<double>(arrival - last) * 1e-6);
        if (arrival >= first + static_cast<std::int64_t>(kSettleS * 1e9))
            steady.push_back(all.back());
    }
    return {all, steady};
}

void print_registered(const fs::path& extrinsics) {
    for (const auto& e : io::read_extrinsics_yaml(extrinsics, nullptr)) {
        if (e.name != "station0")
            std::printf("segment_%s_registered %d flag\n", e.name.c_str(), e.registered ? 1 : 0);
    }
}

struct Options {
    fs::path case_dir;
    int stations = 2;
    double seconds = 10;
    double thin_m = 0;
    std::string daemon = bench::built_daemon_path();
    bool keep = false;
};

int run(const Options& o) {
    const std::vector<std::int64_t> frames = recorded_frames(o.case_dir / "F0");
    if (frames.empty()) {
        std::fprintf(stderr, "segment_latency_bench: no fused_<k>.ply in %s\n",
                     (o.case_dir / "F0").c_str());
        return 1;
    }
    std::vector<std::vector<core::FusedCloud>> clouds;
    for (int j = 0; j < o.stations; ++j)
        clouds.push_back(station_clouds(o.case_dir / ("F" + std::to_string(j)), frames, o.thin_m));
    const fs::path dir =
        fs::temp_directory_path() / ("segment_latency_bench_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const int domain = 1 + static_cast<int>(::getpid() % 230);
    write_config(dir / "segment.yaml", dir / "out", o.stations, domain);
    const std::string uri = bench::cyclone_uri("bench");
    const pid_t pid = bench::start_daemon(o.daemon, dir / "segment.yaml", dir / "segment.log", uri);
    bench::set_cyclone_uri(uri);
    StationWriters writers(domain, o.stations);
    if (!writers.ok()) {
        std::fprintf(stderr, "segment_latency_bench: cannot create the station writers\n");
        bench::stop_daemon(pid);
        return 1;
    }
    bench::Received received;
    std::atomic<bool> stop{false}, matched{false};
    std::thread reader([&] {
        bench::subscribe(domain, {uri, uri, true, 20, ""}, &stop, &matched, &received);
    });
    for (int i = 0; i < 1000 && !matched.load(); ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const auto cpu0 = bench::usage_by_stage(pid);
    const double bench_cpu0 = bench::process_cpu_s();
    const std::vector<Published> published = play(clouds, &writers, o.seconds);
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // the segment catches up
    const auto cpu1 = bench::usage_by_stage(pid);
    const double wall_s = o.seconds + 1.5;
    const double bench_cpu_s = bench::process_cpu_s() - bench_cpu0;
    const double rss = bench::peak_rss_mib(pid);
    const bool clean = bench::stop_daemon(pid);
    stop = true;
    reader.join();

    const std::string tag = std::to_string(o.stations) + "stations";
    std::printf("segment_station_cloud_points_%s %.0f points\n", tag.c_str(),
                static_cast<double>(clouds[0][0].points.size()));
    std::printf(
        "segment_station_cloud_bytes_%s %.0f bytes\n", tag.c_str(),
        published[0].clouds ? published[0].bytes / static_cast<double>(published[0].clouds) : 0.0);
    std::printf("segment_station_bandwidth_%s %.1f MB/s\n", tag.c_str(),
                published[0].bytes / o.seconds * 1e-6);
    const auto [all, steady] = latencies(received, published);
    std::printf("segment_latency_median_%s %.1f ms\n", tag.c_str(), bench::percentile(all, 0.5));
    std::printf("segment_latency_p99_%s %.1f ms\n", tag.c_str(), bench::percentile(all, 0.99));
    std::printf("segment_latency_median_steady_%s %.1f ms\n", tag.c_str(),
                bench::percentile(steady, 0.5));
    std::printf("segment_latency_p99_steady_%s %.1f ms\n", tag.c_str(),
                bench::percentile(steady, 0.99));
    std::printf("segment_clouds_received_%s %zu frames\n", tag.c_str(),
                received.cloud_arrival_ns.size());
    std::printf("segment_frames_played_%s %zu frames\n", tag.c_str(), published[0].clouds);
    const std::pair<const char*, const char*> figures[] = {{"frames_fused", "frames"},
                                                           {"frames_predicted", "frames"},
                                                           {"frame_queue_drops", "frames"},
                                                           {"last_initial_registration_ms", "ms"},
                                                           {"mean_fusion_ms", "ms"}};
    for (const auto& [key, unit] : figures) {
        std::printf("segment_%s_%s %s %s\n", key, tag.c_str(),
                    bench::diagnostic_value(&received, bench::kBenchPipelineStatus, key).c_str(),
                    unit);
    }
    for (const char* stage : {"fusion", "initial", "output", "dds", "sync", "main"}) {
        const bench::StageUsage before = cpu0.count(stage) ? cpu0.at(stage) : bench::StageUsage{};
        const bench::StageUsage after = cpu1.count(stage) ? cpu1.at(stage) : before;
        std::printf("segment_cpu_%s_%s %.1f %%\n", stage, tag.c_str(),
                    100.0 * (after.cpu_s - before.cpu_s) / wall_s);
    }
    std::printf("segment_bench_cpu_%s %.1f %%\n", tag.c_str(), 100.0 * bench_cpu_s / wall_s);
    std::printf("segment_peak_rss_%s %.1f MiB\n", tag.c_str(), rss);
    std::printf("segment_daemon_exit_clean_%s %d flag\n", tag.c_str(), clean ? 1 : 0);
    print_registered(dir / "out" / "extrinsics.yaml");
    if (o.keep)
        std::printf("segment_work_dir %s path\n", dir.c_str());
    else
        fs::remove_all(dir);
    return clean ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 4) {
        std::fprintf(stderr,
                     "usage: %s CASE STATIONS SECONDS [--thin M] [--daemon PATH] [--keep 1]\n",
                     argv[0]);
        return 2;
    }
    Options o;
    o.case_dir = argv[1];
    o.stations = std::stoi(argv[2]);
    o.seconds = std::stod(argv[3]);
    for (int i = 4; i + 1 < argc; i += 2) {
        const std::string arg = argv[i];
        if (arg == "--thin") {
            o.thin_m = std::stod(argv[i + 1]);
        } else if (arg == "--daemon") {
            o.daemon = argv[i + 1];
        } else if (arg == "--keep") {
            o.keep = argv[i + 1] == std::string("1");
        } else {
            std::fprintf(stderr, "segment_latency_bench: unknown option %s\n", arg.c_str());
            return 2;
        }
    }
    try {
        return run(o);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "segment_latency_bench: %s\n", e.what());
        return 1;
    }
}

#include "drivers/sim/simulator.hpp"

#include <algorithm>
#include <atomic>
#include <optional>
#include <stdexcept>
#include <thread>

#include "core/common/stopwatch.hpp"
#include "drivers/ouster/packet_format.hpp"
#include "drivers/sim/packet_encoder.hpp"
#include "drivers/sim/ray_caster.hpp"
#include "drivers/sim/rng.hpp"

namespace lidarfuse::sim {

struct Simulator::Impl {
    explicit Impl(int threads) : device(threads) {}
    RayDevice device;
    std::unique_ptr<StaticScene> static_scene;
    std::vector<ColumnRenderer> renderers;
    std::vector<ouster::PacketFormat> formats;
};

namespace {

void check_params(const SimParams& p) {
    std::vector<std::string> problems;
    if (p.sensors < 1 || p.sensors > 16) problems.push_back("--sensors must be in 1..16");
    if (p.stations < 1 || p.sensors % p.stations != 0) {
        problems.push_back("--stations must be at least 1 and divide the sensors");
    }
    if (!(p.seconds > 0) || p.seconds > 3600) problems.push_back("--seconds must be in (0, 3600]");
    if (!ouster::parse_lidar_mode(std::to_string(p.columns_per_frame) + "x" +
                                  std::to_string(p.frames_per_second))) {
        problems.push_back(
            "--mode must be one of Ouster's modes (512x10, 512x20, 1024x10, "
            "1024x20, 2048x10, 4096x5)");
    }
    if (p.sensor.noise_sigma_m < 0 || p.sensor.noise_sigma_m > 1) {
        problems.push_back("--noise-sigma-m must be in [0, 1]");
    }
    if (p.profile != ouster::UdpProfileLidar::kLegacy &&
        p.profile != ouster::UdpProfileLidar::kRng19Rfl8Sig16Nir16 &&
        p.profile != ouster::UdpProfileLidar::kRng15Rfl8Nir8) {
        problems.push_back("--profile must be LEGACY, RNG19_RFL8_SIG16_NIR16 or RNG15_RFL8_NIR8");
    }
    if (p.first_lidar_port < 1024 || p.first_lidar_port + 2 * p.sensors > 65535) {
        problems.push_back("the first lidar port must be in 1024..65535 - 2 * sensors");
    }
    if (!problems.empty()) {
        std::string all = "sim: invalid parameters:";
        for (const auto& s : problems) all += "\n  " + s;
        throw std::invalid_argument(all);
    }
}

std::uint64_t frame_key(std::uint64_t seed, int sensor, int frame) {
    return mix64(mix64(mix64(seed ^ 0x72656E646572ULL) ^ static_cast<std::uint64_t>(sensor)) ^
                 static_cast<std::uint64_t>(frame));
}

}  // namespace

Simulator::Simulator(const SimParams& params) : params_(params) {
    check_params(params);
    scene_ = build_scene(
        {params.scenario, params.sensors, params.seed, params.stations, params.station_spacing_m});
    const int per_station = params.sensors / params.stations;
    frames_ = std::max(1, static_cast<int>(std::lround(params.seconds * params.frames_per_second)));
    for (int k = 0; k < params.sensors; ++k) {
        SensorRigParams rp;
        rp.index = k;
        if (params.stations > 1) {
            rp.station = k / per_station;
            rp.index_in_station = k % per_station;
        }
        rp.columns_per_frame = params.columns_per_frame;
        rp.frames_per_second = params.frames_per_second;
        rp.profile = params.profile;
        rp.seed = params.seed;
        rp.motion = params.motion;
        rp.duration_s = params.seconds + 1.0;
        rp.first_lidar_port = params.first_lidar_port;
        rigs_.emplace_back(scene_.mounts[static_cast<std::size_t>(k)], rp);
    }
    if (params.traffic) {
        TrafficParams tp;
        tp.duration_s = params.seconds + 1.0;
        tp.seed = params.seed;
        traffic_ = std::make_unique<Traffic>(scene_, tp);
    }
    impl_ = std::make_unique<Impl>(params.threads);
    impl_->static_scene = std::make_unique<StaticScene>(impl_->device, scene_.mesh);
    for (const auto& rig : rigs_) {
        impl_->renderers.emplace_back(rig.info(), params.sensor);
        impl_->formats.emplace_back(rig.info());
    }
}

Simulator::~Simulator() = default;

std::int64_t Simulator::column_time_ns(int sensor, int frame, int m) const {
    const std::int64_t frame_ns = 1'000'000'000LL / params_.frames_per_second;
    return kEpochNs + rigs_[static_cast<std::size_t>(sensor)].phase_ns() + frame * frame_ns +
           frame_ns * m / params_.columns_per_frame;
}

std::vector<io::PoseRecord> Simulator::ground_truth() const {
    std::vector<io::PoseRecord> out;
    for (int f = 0; f < frames_; ++f) {
        for (const auto& rig : rigs_) {
            const std::int64_t t = column_time_ns(rig.index(), f, 0);
            out.push_back(
                {f, rig.name(), t, rig.T_world_sensor(static_cast<double>(t - kEpochNs) * 1e-9)});
        }
    }
    return out;
}

namespace {

constexpr int kColumnsPerPacket = 16;  // Ouster: 16 columns per lidar packet
constexpr int kMaxRows = 64;

// packets[k][p]: sensor k's lidar packet p of the frame being rendered.
using FramePackets = std::vector<std::vector<std::vector<std::uint8_t>>>;

// One frame's render tasks (one per sensor and packet), shared by the render threads. They
// only read it, except: `next` hands out the tasks, and task t writes only its own packet and
// task_returns[t], so no two threads write the same memory.
struct FrameRenderJob {
    const Simulator* sim;
    const std::vector<ColumnRenderer>* renderers;
    const std::vector<ouster::PacketFormat>* formats;
    const StaticScene* static_scene;
    const std::vector<std::unique_ptr<DynamicScene>>* dynamic;  // per sensor, may hold null
    int frame;
    int packets_per_frame;
    std::atomic<int>* next;
    FramePackets* packets;
    std::vector<std::uint64_t>* task_returns;  // pixels with a return, per task
};

// Renders the columns of packet p of sensor k and encodes the packet; px: scratch pixels.
void render_task(const FrameRenderJob& job, int task, std::vector<PixelReturn>* px) {
    const SimParams& params = job.sim->params();
    const int f = job.frame;
    const int k = task / job.packets_per_frame, p = task % job.packets_per_frame;
    const SensorRig& rig = job.sim->rigs()[static_cast<std::size_t>(k)];
    const ColumnRenderer& renderer = (*job.renderers)[static_cast<std::size_t>(k)];
    const int rows = renderer.rows();
    px->resize(static_cast<std::size_t>(kColumnsPerPacket * rows));
    const std::int64_t frame_ns = 1'000'000'000LL / params.frames_per_second;
    const std::uint64_t key = frame_key(params.seed, k, f);
    const std::int64_t start = job.sim->column_time_ns(k, f, 0);
    const std::int64_t clock_offset = params.faults.clock_offset_ns(k);
    std::uint64_t ts[kColumnsPerPacket];  // column timestamps as the sensor's clock has them
    std::uint64_t returns = 0;
    for (int c = 0; c < kColumnsPerPacket; ++c) {
        const int m = p * kColumnsPerPacket + c;
        const std::int64_t t_ns = job.sim->column_time_ns(k, f, m);
        ts[c] = static_cast<std::uint64_t>(t_ns + clock_offset);
        const double t_s = static_cast<double>(t_ns - kEpochNs) * 1e-9;
        const auto time01 =
            static_cast<float>(static_cast<double>(t_ns - start) / static_cast<double>(frame_ns));
        returns += static_cast<std::uint64_t>(renderer.render(
            *job.static_scene, (*job.dynamic)[k].get(), time01, rig.T_world_sensor(t_s), m, key,
            px->data() + static_cast<std::ptrdiff_t>(c * rows)));
    }
    const double t_first = static_cast<double>(start - kEpochNs) * 1e-9;
    PacketHeaderValues h;
    h.frame_id = static_cast<std::uint16_t>(rig.first_frame_id() + f);
    h.init_id = params.faults.init_id_at(k, rig.info().init_id, t_first);
    h.serial = rig.info().serial_number();
    encode_lidar_packet((*job.formats)[k], h, p * kColumnsPerPacket, params.columns_per_frame, ts,
                        px->data(), (*job.packets)[k][p].data());
    (*job.task_returns)[static_cast<std::size_t>(task)] = returns;
}

// One render thread: takes tasks until none is left.
void render_tasks(const FrameRenderJob& job) {
    std::vector<PixelReturn> px(static_cast<std::size_t>(kColumnsPerPacket * kMaxRows));
    const int num_tasks = job.sim->params().sensors * job.packets_per_frame;
    for (int task; (task = job.next->fetch_add(1)) < num_tasks;) render_task(job, task, &px);
}

// Runs the job on `threads` threads, this one included.
void render_frame(const FrameRenderJob& job, int threads) {
    std::vector<std::thread> pool;
    for (int i = 1; i < threads; ++i) pool.emplace_back(render_tasks, std::cref(job));
    render_tasks(job);
    for (auto& t : pool) t.join();
}

// The moving boxes of each sensor's frame f, over the frame's span of time (s since the epoch).
std::vector<std::unique_ptr<DynamicScene>> dynamic_scenes(const Simulator& sim,
                                                          const RayDevice& device, int f,
                                                          std::vector<MovingBox>* boxes) {
    const int n = sim.params().sensors;
    const std::int64_t frame_ns = 1'000'000'000LL / sim.params().frames_per_second;
    std::vector<std::unique_ptr<DynamicScene>> dynamic(static_cast<std::size_t>(n));
    if (sim.traffic()) {
        for (int k = 0; k < n; ++k) {
            const double t0 = static_cast<double>(sim.column_time_ns(k, f, 0) - kEpochNs) * 1e-9;
            sim.traffic()->moving_boxes(t0, t0 + static_cast<double>(frame_ns) * 1e-9, boxes);
            dynamic[k] = std::make_unique<DynamicScene>(device, *boxes);
        }
    }
    return dynamic;
}

// The network between the sensors and the capturing host: latency, jitter and faults per
// packet; datagrams wait in capture-time order until flushed to the sink.
class SimNetwork {
public:
    explicit SimNetwork(const Simulator& sim)
        : sim_(sim),
          held_(static_cast<std::size_t>(sim.params().sensors)),
          sequence_(static_cast<std::size_t>(sim.params().sensors), 0) {}

    // Frame f's packets, per sensor in sending order.
    void send_frame(int f, const FramePackets& packets) {
        for (int k = 0; k < sim_.params().sensors; ++k) {
            for (std::size_t p = 0; p < packets[k].size(); ++p) {
                send_packet(k, f, static_cast<int>(p), packets[k][p]);
            }
        }
    }

    // Packets still held back for reordering go out last.
    void release_held() {
        for (auto& h : held_) {
            if (h) pending_.push_back(std::move(*h));
        }
    }

    // Writes the datagrams captured before before_ns (ns since the epoch) to the sink in
    // capture order (ties: by sensor).
    void flush(std::int64_t before_ns, DatagramSink& sink, SimStats* stats) {
        std::stable_sort(pending_.begin(), pending_.end(),
                         [](const SimDatagram& a, const SimDatagram& b) {
                             return a.capture_ns != b.capture_ns ? a.capture_ns < b.capture_ns
                                                                 : a.sensor < b.sensor;
                         });
        std::size_t i = 0;
        for (; i < pending_.size() && pending_[i].capture_ns < before_ns; ++i) {
            sink.write(pending_[i]);
            ++stats->datagrams_sent;
        }
        pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(i));
    }

private:
    void send_packet(int k, int f, int p, const std::vector<std::uint8_t>& pkt) {
        const SimParams& params = sim_.params();
        const SensorRig& rig = sim_.rigs()[static_cast<std::size_t>(k)];
        const std::int64_t t_last =
            sim_.column_time_ns(k, f, p * kColumnsPerPacket + kColumnsPerPacket - 1);
        const std::uint64_t seq = sequence_[k]++;
        CounterRng jitter(params.seed ^ 0x6E6574ULL, static_cast<std::uint64_t>(k), seq);
        SimDatagram d;
        // Latency 30 us plus up to 40 us of jitter after the packet's last column.
        d.capture_ns = t_last + 30'000 + static_cast<std::int64_t>(jitter.uniform() * 40'000);
        d.sensor = k;
        d.src_ip = rig.src_ip();
        d.dst_ip = kHostIp;
        d.src_port = rig.lidar_port();
        d.dst_port = rig.lidar_port();
        const PacketFate fate =
            packet_fate(params.faults, params.seed, k, seq,
                        static_cast<double>(t_last - kEpochNs) * 1e-9, pkt.size());
        if (fate.drop) return;
        d.payload.assign(pkt.begin(), pkt.end());
        if (fate.truncate_to > 0) d.payload.resize(fate.truncate_to);
        queue(k, fate, std::move(d));
    }

    void queue(int k, const PacketFate& fate, SimDatagram&& d) {
        if (held_[k]) {  // a packet held back by `reorder` goes out after this one
            held_[k]->capture_ns = d.capture_ns + 1'000;
            pending_.push_back(d);
            pending_.push_back(std::move(*held_[k]));
            held_[k].reset();
            return;
        }
        if (fate.reorder) {
            held_[k] = d;
            return;
        }
        if (fate.duplicate) {
            SimDatagram dup = d;
            dup.capture_ns += 2'000;
            pending_.push_back(std::move(dup));
        }
        pending_.push_back(std::move(d));
    }

    const Simulator& sim_;
    std::vector<SimDatagram> pending_;
    std::vector<std::optional<SimDatagram>> held_;  // per sensor
    std::vector<std::uint64_t> sequence_;           // per sensor, packets sent
};

}  // namespace

SimStats Simulator::run(DatagramSink& sink) {
    SimStats stats;
    const int n = params_.sensors;
    const int P = params_.columns_per_frame / kColumnsPerPacket;
    const int threads = params_.threads > 0
                            ? params_.threads
                            : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    FramePackets packets(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) {
        packets[k].assign(static_cast<std::size_t>(P),
                          std::vector<std::uint8_t>(impl_->formats[k].lidar_packet_size()));
    }
    std::vector<std::uint64_t> task_returns(static_cast<std::size_t>(n * P));
    SimNetwork network(*this);
    std::vector<MovingBox> boxes;
    for (int f = 0; f < frames_; ++f) {
        const core::Stopwatch render_time;
        const auto dynamic = dynamic_scenes(*this, impl_->device, f, &boxes);
        std::atomic<int> next{0};
        render_frame({this, &impl_->renderers, &impl_->formats, impl_->static_scene.get(), &dynamic,
                      f, P, &next, &packets, &task_returns},
                     threads);
        stats.render_wall_s += render_time.seconds();
        for (auto r : task_returns) stats.returns += r;
        stats.rays += static_cast<std::uint64_t>(n) *
                      static_cast<std::uint64_t>(params_.columns_per_frame) * 64u;
        stats.packets_rendered += static_cast<std::uint64_t>(n * P);

        network.send_frame(f, packets);
        // Everything captured before the next frame's first column is final.
        std::int64_t boundary = INT64_MAX;
        for (int k = 0; k < n; ++k) boundary = std::min(boundary, column_time_ns(k, f + 1, 0));
        network.flush(boundary, sink, &stats);
        if (on_frame_) on_frame_(f + 1, frames_);
    }
    network.release_held();
    network.flush(INT64_MAX, sink, &stats);
    return stats;
}

}  // namespace lidarfuse::sim

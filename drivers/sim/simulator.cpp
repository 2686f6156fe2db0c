#include "drivers/sim/simulator.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <thread>

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
    scene_ = build_scene({params.scenario, params.sensors, params.seed});
    frames_ = std::max(1, static_cast<int>(std::lround(params.seconds * params.frames_per_second)));
    for (int k = 0; k < params.sensors; ++k) {
        SensorRigParams rp;
        rp.index = k;
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

SimStats Simulator::run(DatagramSink& sink) {
    SimStats stats;
    const int n = params_.sensors;
    const int W = params_.columns_per_frame;
    const int cpp = 16;
    const int P = W / cpp;
    const std::int64_t frame_ns = 1'000'000'000LL / params_.frames_per_second;
    const int threads = params_.threads > 0
                            ? params_.threads
                            : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    std::vector<std::vector<std::vector<std::uint8_t>>> packets(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) {
        packets[k].assign(static_cast<std::size_t>(P),
                          std::vector<std::uint8_t>(impl_->formats[k].lidar_packet_size()));
    }
    std::vector<std::uint64_t> task_returns(static_cast<std::size_t>(n * P));
    std::vector<SimDatagram> pending;
    std::vector<std::optional<SimDatagram>> held(static_cast<std::size_t>(n));
    std::vector<std::uint64_t> sequence(static_cast<std::size_t>(n), 0);
    std::vector<MovingBox> boxes;

    auto flush = [&](std::int64_t before_ns) {
        std::stable_sort(pending.begin(), pending.end(),
                         [](const SimDatagram& a, const SimDatagram& b) {
                             return a.capture_ns != b.capture_ns ? a.capture_ns < b.capture_ns
                                                                 : a.sensor < b.sensor;
                         });
        std::size_t i = 0;
        for (; i < pending.size() && pending[i].capture_ns < before_ns; ++i) {
            sink.write(pending[i]);
            ++stats.datagrams_sent;
        }
        pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(i));
    };

    for (int f = 0; f < frames_; ++f) {
        const auto wall0 = std::chrono::steady_clock::now();
        std::vector<std::unique_ptr<DynamicScene>> dynamic(static_cast<std::size_t>(n));
        if (traffic_) {
            for (int k = 0; k < n; ++k) {
                const double t0 = static_cast<double>(column_time_ns(k, f, 0) - kEpochNs) * 1e-9;
                traffic_->moving_boxes(t0, t0 + static_cast<double>(frame_ns) * 1e-9, &boxes);
                dynamic[k] = std::make_unique<DynamicScene>(impl_->device, boxes);
            }
        }
        std::atomic<int> next{0};
        auto worker = [&]() {
            std::vector<PixelReturn> px(static_cast<std::size_t>(cpp * 64));
            std::uint64_t ts[16];
            for (int task; (task = next.fetch_add(1)) < n * P;) {
                const int k = task / P, p = task % P;
                const SensorRig& rig = rigs_[static_cast<std::size_t>(k)];
                const ColumnRenderer& renderer = impl_->renderers[static_cast<std::size_t>(k)];
                const int rows = renderer.rows();
                px.resize(static_cast<std::size_t>(cpp * rows));
                const std::uint64_t key = frame_key(params_.seed, k, f);
                const std::int64_t start = column_time_ns(k, f, 0);
                const std::int64_t clock_offset = params_.faults.clock_offset_ns(k);
                std::uint64_t returns = 0;
                for (int c = 0; c < cpp; ++c) {
                    const int m = p * cpp + c;
                    const std::int64_t t_ns = column_time_ns(k, f, m);
                    ts[c] = static_cast<std::uint64_t>(t_ns + clock_offset);
                    const double t_s = static_cast<double>(t_ns - kEpochNs) * 1e-9;
                    const auto time01 = static_cast<float>(static_cast<double>(t_ns - start) /
                                                           static_cast<double>(frame_ns));
                    returns += static_cast<std::uint64_t>(renderer.render(
                        *impl_->static_scene, dynamic[k].get(), time01, rig.T_world_sensor(t_s), m,
                        key, px.data() + static_cast<std::ptrdiff_t>(c * rows)));
                }
                const double t_first = static_cast<double>(start - kEpochNs) * 1e-9;
                PacketHeaderValues h;
                h.frame_id = static_cast<std::uint16_t>(rig.first_frame_id() + f);
                h.init_id = params_.faults.init_id_at(k, rig.info().init_id, t_first);
                h.serial = rig.info().serial_number();
                encode_lidar_packet(impl_->formats[k], h, p * cpp, W, ts, px.data(),
                                    packets[k][p].data());
                task_returns[static_cast<std::size_t>(task)] = returns;
            }
        };
        std::vector<std::thread> pool;
        for (int i = 1; i < threads; ++i) pool.emplace_back(worker);
        worker();
        for (auto& t : pool) t.join();
        stats.render_wall_s +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
        for (auto r : task_returns) stats.returns += r;
        stats.rays += static_cast<std::uint64_t>(n) * static_cast<std::uint64_t>(W) * 64u;
        stats.packets_rendered += static_cast<std::uint64_t>(n * P);

        // Network: latency, jitter and faults, per sensor in sending order.
        for (int k = 0; k < n; ++k) {
            const SensorRig& rig = rigs_[static_cast<std::size_t>(k)];
            for (int p = 0; p < P; ++p) {
                const std::int64_t t_last = column_time_ns(k, f, p * cpp + cpp - 1);
                const std::uint64_t seq = sequence[k]++;
                CounterRng jitter(params_.seed ^ 0x6E6574ULL, static_cast<std::uint64_t>(k), seq);
                SimDatagram d;
                d.capture_ns =
                    t_last + 30'000 + static_cast<std::int64_t>(jitter.uniform() * 40'000);
                d.sensor = k;
                d.src_ip = rig.src_ip();
                d.dst_ip = kHostIp;
                d.src_port = rig.lidar_port();
                d.dst_port = rig.lidar_port();
                const auto& pkt = packets[k][p];
                const PacketFate fate =
                    packet_fate(params_.faults, params_.seed, k, seq,
                                static_cast<double>(t_last - kEpochNs) * 1e-9, pkt.size());
                if (fate.drop) continue;
                d.payload.assign(pkt.begin(), pkt.end());
                if (fate.truncate_to > 0) d.payload.resize(fate.truncate_to);
                if (held[k]) {  // a packet held back by `reorder` goes out after this one
                    held[k]->capture_ns = d.capture_ns + 1'000;
                    pending.push_back(d);
                    pending.push_back(std::move(*held[k]));
                    held[k].reset();
                    continue;
                }
                if (fate.reorder) {
                    held[k] = d;
                    continue;
                }
                if (fate.duplicate) {
                    SimDatagram dup = d;
                    dup.capture_ns += 2'000;
                    pending.push_back(std::move(dup));
                }
                pending.push_back(std::move(d));
            }
        }
        std::int64_t boundary = INT64_MAX;
        for (int k = 0; k < n; ++k) boundary = std::min(boundary, column_time_ns(k, f + 1, 0));
        flush(boundary);
        if (on_frame_) on_frame_(f + 1, frames_);
    }
    for (auto& h : held) {
        if (h) pending.push_back(std::move(*h));
    }
    flush(INT64_MAX);
    return stats;
}

}  // namespace lidarfuse::sim

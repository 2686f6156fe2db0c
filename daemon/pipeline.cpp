#include "daemon/pipeline.hpp"

#include <pthread.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "daemon/pipeline_impl.hpp"
#include "drivers/net/ipv4_address.hpp"

namespace lidarfuse::daemon {

const char* to_string(SensorState state) {
    switch (state) {
        case SensorState::kOk:
            return "OK";
        case SensorState::kStale:
            return "STALE";
        case SensorState::kLost:
            return "LOST";
        case SensorState::kDisabled:
            return "DISABLED";
        case SensorState::kModeMismatch:
            return "MODE_MISMATCH";
        case SensorState::kNoMetadata:
            return "NO_METADATA";
        case SensorState::kClockSkew:
            return "CLOCK_SKEW";
    }
    return "?";
}

using Clock = std::chrono::steady_clock;

namespace {

// A receiver that waits for CPU behind registration loses packets for good once its socket
// buffer fills; a fusion thread that waits only delivers a frame later. So the compute
// threads (fusion, output) run this much nicer than the process, and so do the threads they
// start (the initial-registration worker, their OpenMP teams): Linux keeps a nice value per
// thread and a new thread inherits its creator's. Raising one needs no privilege.
constexpr int kComputeNiceOffset = 5;

void lower_this_thread_priority(const char* name) {
    const id_t tid = static_cast<id_t>(::gettid());
    errno = 0;
    const int now = ::getpriority(PRIO_PROCESS, tid);
    if (errno != 0 ||
        ::setpriority(PRIO_PROCESS, tid, std::min(now + kComputeNiceOffset, 19)) != 0) {
        spdlog::warn("{}: cannot lower its priority: {}", name, std::strerror(errno));
    }
}

// A sensor whose metadata is a file: loaded before any thread starts (errors stop start-up).
void load_metadata_file(const station::SensorConfig& sc, SensorIngest* s) {
    s->adopt_metadata(ouster::load_metadata(sc.metadata));
    s->metadata_status.source = sc.metadata.string();
}

}  // namespace

Pipeline::Impl::Impl(const DaemonConfig& c)
    : config(c),
      frames(static_cast<std::size_t>(c.sync.queue_depth)),
      results(static_cast<std::size_t>(c.sync.queue_depth)) {
    ingest_log = logger("ingest");
    sync_log = logger("sync");
    fusion_log = logger("fusion");
    output_log = logger("output");
    const PortMembers by_port = make_sensors();
    make_recorder();
    make_fetchers();
    make_receivers(by_port);
    make_fusion();
    make_publishers();
    make_dds_inputs();
    heartbeat_ns = steady_ns();
}

// Every configured sensor, and the enabled ones by UDP port. A sensor whose metadata is a
// file has it now; every file that fails to load is listed in one exception.
Pipeline::Impl::PortMembers Pipeline::Impl::make_sensors() {
    PortMembers by_port;
    std::vector<std::string> problems;
    for (std::size_t i = 0; i < config.station.sensors.size(); ++i) {
        const auto& sc = config.station.sensors[i];
        auto s = std::make_unique<SensorIngest>();
        s->index = i;
        s->name = sc.name;
        s->time_offset_ns = sc.time_offset_ns;
        s->udp_port = sc.udp_port;
        if (sc.dds) {
            // Its DdsInput (make_dds_inputs) brings its clouds; no port, no metadata.
        } else if (sc.enabled && sc.hostname) {
            by_port[sc.udp_port].push_back(s.get());  // its fetcher brings the metadata
        } else if (sc.enabled) {
            try {
                load_metadata_file(sc, s.get());
                by_port[sc.udp_port].push_back(s.get());
            } catch (const std::exception& error) {
                problems.push_back("sensor \"" + sc.name + "\": " + error.what());
            }
        }
        sensors.push_back(std::move(s));
    }
    if (!problems.empty()) {
        std::string text = "cannot start: sensor metadata";
        for (const auto& p : problems) text += "\n  " + p;
        throw std::runtime_error(text);
    }
    return by_port;
}

void Pipeline::Impl::make_recorder() {
    if (!config.output.record.enabled) return;
    const std::uint32_t dst_ip = net::parse_ipv4(config.network.bind_address);  // 0.0.0.0: 0
    RecordConfig record = config.output.record;
    record.directory = record_directory(config.output);
    recorder = std::make_unique<Recorder>(record, config.station, dst_ip, logger("record"));
}

// One per enabled sensor named by hostname.
void Pipeline::Impl::make_fetchers() {
    for (std::size_t i = 0; i < config.station.sensors.size(); ++i) {
        const auto& sc = config.station.sensors[i];
        if (!sc.enabled || !sc.hostname) continue;
        MetadataFetcherParams params;
        params.http.host = *sc.hostname;
        params.http.port = sc.http_port;
        fetchers.push_back(std::make_unique<MetadataFetcher>(
            sensors[i].get(), sc, params, config.output.directory, recorder.get(), ingest_log));
    }
}

void Pipeline::Impl::make_receivers(const PortMembers& by_port) {
    for (const auto& [port, members] : by_port) {
        receivers.push_back(make_receiver(port, members, config.network, config.station,
                                          config.health.min_completeness));
        receivers.back()->log = ingest_log;
        receivers.back()->recorder = recorder.get();
        receivers.back()->queue.set_doorbell(&scans_ready);
    }
}

void Pipeline::Impl::make_fusion() {
    engine = std::make_unique<core::FusionEngine>(sensors.size(), config.fusion);
    core::WorldFrameParams world_params = config.world.params;
    world_params.settle_frames = core::world_frame_settle_frames(config.fusion);
    world = std::make_unique<core::WorldFrameTracker>(world_params, sensors.size());
    world_frame = world->frame();
    last_health.assign(sensors.size(), core::SensorHealth{});
    offset_to_root_ms.assign(sensors.size(), 0.0);
}

// output.dds, and output.foxglove mirroring it (the config check refuses output.foxglove
// without output.dds).
void Pipeline::Impl::make_publishers() {
    if (!config.output.dds.enabled) return;
    StationFrames names;
    names.station = config.station.station;
    names.fused_frame = fused_frame_of(config.output.dds);
    for (const auto& sc : config.station.sensors) names.sensor_names.push_back(sc.name);
    names.root = config.fusion.root_sensor;
    names.sensor_frames = sensor_frames_of(config.station, config.output.dds);
    // geo: the world frame is the fused frame's parent on rt/tf_static (the offset).
    const bool geo = config.world.params.kind == core::WorldFrameKind::kGeo;
    dds =
        std::make_unique<DdsPublisher>(config.output.dds, names, geo ? config.world.frame_id : "");
    if (!config.output.foxglove.enabled) return;
    foxglove = std::make_unique<FoxgloveServer>(
        config.output.foxglove,
        foxglove_channels(config.output.dds.topic_namespace,
                          config.output.dds.points_voxel_size_m > 0),
        "lidarfused " + config.station.station, logger("foxglove"));
    dds->mirror_to(foxglove.get());
}

// One per enabled sensor with source.dds. A source that is one of this daemon's own cloud
// topics in its domain would feed the fused cloud back as a scan: refused.
void Pipeline::Impl::make_dds_inputs() {
    for (std::size_t i = 0; i < config.station.sensors.size(); ++i) {
        const auto& sc = config.station.sensors[i];
        if (!sc.enabled || !sc.dds) continue;
        if (dds && sc.dds->domain_id == dds->domain_id()) {
            const std::string& ns = config.output.dds.topic_namespace;
            for (const char* leaf : {"points", "points_voxel"}) {
                if (sc.dds->topic != ros_topic_name(ns, leaf)) continue;
                throw std::runtime_error("cannot start: sensors[" + std::to_string(i) + "] (\"" +
                                         sc.name + "\"): source.dds.topic " + sc.dds->topic +
                                         " is this daemon's own output in domain " +
                                         std::to_string(sc.dds->domain_id));
            }
        }
        dds_inputs.push_back(std::make_unique<DdsInput>(sensors[i].get(), *sc.dds, ingest_log));
        dds_inputs.back()->queue().set_doorbell(&scans_ready);
    }
}

std::shared_ptr<spdlog::logger> Pipeline::Impl::logger(const std::string& name) {
    auto existing = spdlog::get(name);
    if (existing) return existing;
    auto l = spdlog::default_logger()->clone(name);
    spdlog::register_logger(l);
    return l;
}

Pipeline::Pipeline(const DaemonConfig& config) : impl_(std::make_unique<Impl>(config)) {}

Pipeline::~Pipeline() { stop(); }

// Thread names (at most 15 characters) let `top -H` and the daemon bench tell the stages
// apart: lf-recv-<port>, lf-sync, lf-fusion (and its lf-init worker), lf-output,
// lf-foxglove.
void Pipeline::start() {
    Impl& m = *impl_;
    for (auto& r : m.receivers) {
        const std::string name = "lf-recv-" + std::to_string(r->socket->sockets().front().port);
        r->thread = std::thread([rp = r.get(), name] {
            ::pthread_setname_np(::pthread_self(), name.c_str());
            run_receiver(rp);
        });
    }
    for (auto& f : m.fetchers) f->start();
    for (auto& d : m.dds_inputs) d->start();
    if (m.foxglove) m.foxglove->start();
    m.sync_thread = std::thread([&m] {
        ::pthread_setname_np(::pthread_self(), "lf-sync");
        m.sync_loop();
    });
    m.fusion_thread = std::thread([&m] {
        ::pthread_setname_np(::pthread_self(), "lf-fusion");
        lower_this_thread_priority("lf-fusion");
        m.fusion_loop();
    });
    m.output_thread = std::thread([&m] {
        ::pthread_setname_np(::pthread_self(), "lf-output");
        lower_this_thread_priority("lf-output");
        m.output_loop();
    });
}

void Pipeline::stop() {
    Impl& m = *impl_;
    if (m.stopping.exchange(true)) {
        // Already stopping: still join whatever runs (the destructor after stop()).
    }
    for (auto& f : m.fetchers) f->stop();  // before the recorder they write into
    for (auto& r : m.receivers) r->socket->stop();
    for (auto& d : m.dds_inputs) d->stop();
    for (auto& r : m.receivers) {
        if (r->thread.joinable()) r->thread.join();
        for (auto* s : r->sensors) publish_counters(s);
    }
    if (m.recorder) m.recorder->stop();  // after the receivers: every datagram they offered
    m.scans_ready.ring();                // the sync thread sees `stopping` now
    if (m.sync_thread.joinable()) m.sync_thread.join();
    m.frames.close();
    if (m.fusion_thread.joinable()) m.fusion_thread.join();
    m.results.close();
    if (m.output_thread.joinable()) m.output_thread.join();
    if (m.foxglove) m.foxglove->stop();  // after the output thread, its only publisher
}

std::chrono::steady_clock::time_point Pipeline::heartbeat() const {
    return Clock::time_point(
        std::chrono::nanoseconds(impl_->heartbeat_ns.load(std::memory_order_acquire)));
}

void Pipeline::request_reopen() { impl_->reopen.store(true); }

int Pipeline::dds_domain_id() const { return impl_->dds ? impl_->dds->domain_id() : -1; }

std::uint16_t Pipeline::foxglove_port() const {
    return impl_->foxglove ? impl_->foxglove->port() : 0;
}

std::vector<std::uint16_t> Pipeline::bound_ports() const {
    std::vector<std::uint16_t> ports;
    for (const auto& r : impl_->receivers) ports.push_back(r->socket->sockets().front().port);
    return ports;
}

PipelineStats Pipeline::stats() const { return impl_->collect_stats(); }

}  // namespace lidarfuse::daemon

#include "daemon/sensor_ingest.hpp"

#include <chrono>
#include <cmath>
#include <ctime>
#include <utility>

#include "drivers/net/ipv4_address.hpp"

namespace lidarfuse::daemon {

std::int64_t steady_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

std::int64_t realtime_ns() {
    timespec ts{};
    ::clock_gettime(CLOCK_REALTIME, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

namespace {

// Runs on the receiver thread: a finished scan is projected and queued for the sync
// thread (the only allocation: one message per scan, never per packet).
void attach_assembler(SensorIngest* s, double min_completeness,
                      DropOldestQueue<ScanMessage>* queue) {
    s->assembler = std::make_unique<ouster::ScanAssembler>(
        s->info, ouster::ScanAssemblerParams{},
        [s, queue, min_completeness](const ouster::LidarScan& scan) {
            const double completeness = scan.completeness();
            s->packet_init_id.store(scan.init_id, std::memory_order_relaxed);
            s->scans.fetch_add(1, std::memory_order_relaxed);
            s->last_completeness.store(completeness, std::memory_order_relaxed);
            if (completeness < 1.0) s->scans_incomplete.fetch_add(1, std::memory_order_relaxed);
            if (s->assembler->mode_check().reject_last_frame()) {
                s->scans_mode_rejected.fetch_add(1, std::memory_order_relaxed);
                return;
            }
            if (completeness < min_completeness) {
                s->scans_rejected.fetch_add(1, std::memory_order_relaxed);
                return;
            }
            // The projection fills a spare message's buffer (0.8 MB for an OS1-64 scan):
            // between scans the receiver holds no points.
            ScanMessage m = s->take_spare_scan();
            if (!ouster::project_scan(scan, s->lut, ouster::ProjectionParams{}, &s->cloud,
                                      &m.points)) {
                return s->spare_scans.give(std::move(m));
            }
            const std::uint64_t t = ouster::scan_reference_time_ns(scan);
            m.sensor = s->index;
            m.t_ns = static_cast<std::int64_t>(t) + s->time_offset_ns;
            ouster::point_times_s(s->cloud, t, &m.point_dt_s);
            ouster::point_intensity(scan, s->cloud, &m.intensity);
            m.complete_steady_ns = steady_ns();
            m.complete_realtime_ns = realtime_ns();
            s->last_scan_steady_ns.store(m.complete_steady_ns, std::memory_order_relaxed);
            s->clock_offset_ns.store(m.t_ns - m.complete_realtime_ns, std::memory_order_relaxed);
            queue->push(std::move(m));
        });
}

// Receiver thread, when the ModeCheck flags or clears the sensor (rare: formats text).
void report_mode_change(Receiver* r, SensorIngest* s) {
    const auto& check = s->assembler->mode_check();
    const bool mismatch = check.mismatch();
    const std::string seen = ouster::describe(check.last_disagreement(), check.expected());
    publish_counters(s);
    if (mismatch) {
        std::lock_guard<std::mutex> lock(s->counters_mutex);
        s->mode_seen = seen;
    }
    s->mode_mismatch.store(mismatch, std::memory_order_relaxed);
    if (!r->log) return;
    if (mismatch) {
        r->log->error(
            "{}: data does not match its metadata, not fused until it does (lidar_mode or "
            "profile changed on the sensor?): {}",
            s->name, seen);
    } else {
        r->log->info(  // a recovery: normal life again
            "{}: data matches its metadata ({} {}) again after {} disagreeing frames: fusing it "
            "again",
            s->name, check.expected().lidar_mode, check.expected().profile,
            check.frames_disagreeing());
    }
}

// Receiver thread: the router over the members that have metadata.
void rebuild_router(Receiver* r) {
    std::vector<ouster::RoutedSensor> routed;
    r->routed_members.clear();
    for (std::size_t i = 0; i < r->sensors.size(); ++i) {
        const SensorIngest* s = r->sensors[i];
        if (!s->has_info) continue;
        ouster::RoutedSensor rs{s->info, std::nullopt};
        const auto& sc = r->station->sensors[s->index];
        if (sc.source_address) rs.source_ip = net::parse_ipv4(*sc.source_address);
        routed.push_back(rs);
        r->routed_members.push_back(i);
    }
    r->router = std::make_unique<ouster::SensorRouter>(routed);
}

// Receiver thread: metadata a fetcher handed over since the last datagram.
void install_pending(Receiver* r) {
    bool any = false;
    for (SensorIngest* s : r->sensors) {
        if (!s->install_pending_metadata(r->min_completeness, &r->queue)) continue;
        any = true;
        if (r->log) {
            r->log->info("{}: metadata installed ({} {}, init_id {}, firmware {}): fusing it",
                         s->name, s->info.lidar_mode, ouster::to_string(s->info.udp_profile_lidar),
                         s->info.init_id, s->info.build_rev);
        }
    }
    if (any) rebuild_router(r);
}

}  // namespace

ScanMessage SensorIngest::take_spare_scan() {
    std::optional<ScanMessage> spare = spare_scans.take();
    if (!spare) return ScanMessage{};
    ScanMessage m;
    m.sensor = index;
    m.points = std::move(spare->points);
    m.point_dt_s = std::move(spare->point_dt_s);
    m.intensity = std::move(spare->intensity);
    m.points.clear();
    m.point_dt_s.clear();
    m.intensity.clear();
    return m;
}

void SensorIngest::adopt_metadata(ouster::SensorInfo next) {
    info = std::move(next);
    info.udp_port_lidar = udp_port;
    lut = ouster::make_xyz_lut(info);
    has_info = true;
    frames_per_second.store(info.frames_per_second, std::memory_order_relaxed);
    metadata_known.store(true, std::memory_order_release);
}

bool SensorIngest::install_pending_metadata(double min_completeness,
                                            DropOldestQueue<ScanMessage>* queue) {
    if (!has_pending.load(std::memory_order_acquire)) return false;
    std::optional<ouster::SensorInfo> next;
    {
        std::lock_guard<std::mutex> lock(pending_mutex);
        next.swap(pending_info);
    }
    if (!next) return false;
    if (assembler) counters_before += assembler->counters();
    adopt_metadata(std::move(*next));
    attach_assembler(this, min_completeness, queue);
    mode_mismatch.store(false, std::memory_order_relaxed);
    publish_counters(this);
    // Last: until here the fetcher must not judge the data against the new metadata.
    has_pending.store(false, std::memory_order_release);
    return true;
}

std::unique_ptr<Receiver> make_receiver(std::uint16_t port,
                                        const std::vector<SensorIngest*>& members,
                                        const NetworkConfig& network,
                                        const station::StationConfig& station,
                                        double min_completeness) {
    auto r = std::make_unique<Receiver>();
    net::UdpReceiverParams params;
    params.bind_address = network.bind_address;
    params.ports = {port};
    params.requested_rcvbuf_bytes = network.receive_buffer_bytes;
    params.coalesce_us = static_cast<int>(std::lround(network.receive_coalesce_ms * 1000.0));
    r->socket = std::make_unique<net::UdpReceiver>(params);
    r->sensors = members;
    r->station = &station;
    r->min_completeness = min_completeness;
    rebuild_router(r.get());
    for (auto* s : members) {
        if (s->has_info) attach_assembler(s, min_completeness, &r->queue);
    }
    return r;
}

void run_receiver(Receiver* r) {
    r->socket->run([r](const net::ReceivedDatagram& d) {
        if (r->recorder) r->recorder->offer(d);
        install_pending(r);
        const int routed = r->router->route(d.src_ip, d.local_port, d.data, d.size);
        if (routed < 0) {
            r->unassigned.fetch_add(1, std::memory_order_relaxed);
            return;
        }
        SensorIngest* s = r->sensors[r->routed_members[static_cast<std::size_t>(routed)]];
        s->assembler->add_packet(d.data, d.size);
        if (s->assembler->mode_check().mismatch() !=
            s->mode_mismatch.load(std::memory_order_relaxed)) {
            report_mode_change(r, s);
        }
        // Publish the counters every 64 packets: a lock per packet would be wasted.
        if ((++s->packets_since_publish & 63) == 0) publish_counters(s);
    });
}

void publish_counters(SensorIngest* s) {
    ouster::AssemblyCounters sum = s->counters_before;
    if (s->assembler) sum += s->assembler->counters();
    std::lock_guard<std::mutex> lock(s->counters_mutex);
    s->counters = sum;
}

}  // namespace lidarfuse::daemon

#pragma once
// Decodes a station's capture with the production ingest: station.yaml -> each sensor's
// metadata -> pcap (with IP reassembly) -> sensor routing (port, source address, serial)
// -> per-sensor scan assembly -> xyz projection. Hands every completed scan to a callback,
// in capture order. `lidarfuse fuse` and `lidarfuse calibrate` run on it; the daemon runs
// the same assembler and projection on live sockets. A capture is one pcap file or a
// recording folder of the daemon (output.record: its files in order, as one capture).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "drivers/ouster/frame_window.hpp"
#include "drivers/ouster/lidar_scan.hpp"
#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/sensor_router.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "drivers/station/station_config.hpp"

namespace lidarfuse::capture {

struct CaptureScan {
    std::size_t sensor = 0;                    // index in the station config
    const ouster::LidarScan* scan = nullptr;   // valid during the callback only
    const ouster::ScanCloud* cloud = nullptr;  // projected, sensor frame; same lifetime
    // The scan's timestamp: column 0's (or the first received column's) sensor time, ns,
    // after the sensor's configured time offset. The instant its pose refers to.
    std::int64_t t_ns = 0;
    std::int64_t sensor_t_ns = 0;      // the same instant on the sensor's own clock
    std::int64_t capture_time_ns = 0;  // pcap time of the datagram that completed it
};

class StationCapture {
public:
    // Loads every enabled sensor's metadata and opens the (first) capture file; throws naming
    // the sensor and file on errors.
    StationCapture(const station::StationConfig& station, const std::filesystem::path& capture);
    ~StationCapture();

    // Decodes the capture to its end (or until on_scan returns false), then flushes the
    // assemblers (their last, possibly partial, frames go to on_scan too).
    void run(const std::function<bool(const CaptureScan&)>& on_scan);

    const station::StationConfig& station() const { return station_; }
    const std::vector<ouster::SensorInfo>& infos() const { return infos_; }
    const ouster::AssemblyCounters& counters(std::size_t sensor) const;
    const ouster::RouterCounters& router_counters() const;
    pcap::PcapReaderStats pcap_stats() const;  // of the files read so far
    const std::string& pcap_warning() const;

private:
    struct Sensor;
    station::StationConfig station_;
    std::vector<std::filesystem::path> files_;
    std::vector<ouster::SensorInfo> infos_;
    std::vector<std::unique_ptr<Sensor>> sensors_;
    std::unique_ptr<ouster::SensorRouter> router_;
    std::unique_ptr<pcap::PcapReader> reader_;  // of the file being read
    pcap::PcapReaderStats stats_;               // of the files read before it
    std::string warning_;
};

}  // namespace lidarfuse::capture

#include "drivers/capture/station_capture.hpp"

#include <stdexcept>

#include "drivers/net/ipv4_address.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/xyz_lut.hpp"

namespace lidarfuse::capture {

struct StationCapture::Sensor {
    std::size_t index = 0;  // in the station config
    std::int64_t time_offset_ns = 0;
    ouster::XyzLut lut;
    std::unique_ptr<ouster::ScanAssembler> assembler;
    ouster::ScanCloud cloud;
};

StationCapture::StationCapture(const station::StationConfig& station,
                               const std::filesystem::path& capture)
    : station_(station) {
    std::vector<ouster::RoutedSensor> routed;
    std::vector<std::string> problems;
    for (std::size_t i = 0; i < station_.sensors.size(); ++i) {
        const auto& config = station_.sensors[i];
        ouster::SensorInfo info;
        try {
            if (config.dds) {
                throw std::runtime_error(
                    "takes its clouds from DDS (source.dds: " + config.dds->topic +
                    "), which only lidarfused reads; a capture holds "
                    "Ouster packets only");
            }
            if (config.metadata.empty()) {
                // Only lidarfused talks to sensors; a recording keeps their metadata.
                throw std::runtime_error(
                    "named by hostname only; reading a capture needs its metadata as a file "
                    "(a recording has it in metadata/" +
                    config.name + ".json)");
            }
            info = ouster::load_metadata(config.metadata);
        } catch (const std::exception& error) {
            problems.push_back("sensor \"" + config.name + "\": " + error.what());
            infos_.push_back(info);
            continue;
        }
        // The station config names the port the data arrives on; it wins over metadata.
        info.udp_port_lidar = config.udp_port;
        infos_.push_back(info);
        if (!config.enabled) continue;
        auto sensor = std::make_unique<Sensor>();
        sensor->index = i;
        sensor->time_offset_ns = config.time_offset_ns;
        sensor->lut = ouster::make_xyz_lut(info);
        ouster::RoutedSensor r{info, std::nullopt};
        if (config.source_address) r.source_ip = net::parse_ipv4(*config.source_address);
        routed.push_back(r);
        sensors_.push_back(std::move(sensor));
    }
    if (!problems.empty()) {
        std::string text = station_.source_file.string() + ": cannot load sensor metadata";
        for (const auto& p : problems) text += "\n  " + p;
        throw std::runtime_error(text);
    }
    router_ = std::make_unique<ouster::SensorRouter>(routed);
    files_ = pcap::capture_files(capture);
    reader_ = std::make_unique<pcap::PcapReader>(files_.front());
}

StationCapture::~StationCapture() = default;

void StationCapture::run(const std::function<bool(const CaptureScan&)>& on_scan) {
    bool keep_going = true;
    std::int64_t capture_time_ns = 0;
    for (auto& sensor_ptr : sensors_) {
        Sensor* sensor = sensor_ptr.get();
        ouster::ScanAssemblerParams params;
        sensor->assembler = std::make_unique<ouster::ScanAssembler>(
            infos_[sensor->index], params, [&, sensor](const ouster::LidarScan& scan) {
                if (!keep_going) return;
                ouster::ProjectionParams projection;
                if (!ouster::project_scan(scan, sensor->lut, projection, &sensor->cloud)) return;
                const auto t = static_cast<std::int64_t>(ouster::scan_reference_time_ns(scan));
                CaptureScan out;
                out.sensor = sensor->index;
                out.scan = &scan;
                out.cloud = &sensor->cloud;
                out.t_ns = t + sensor->time_offset_ns;
                out.sensor_t_ns = t;
                out.capture_time_ns = capture_time_ns;
                keep_going = on_scan(out);
            });
    }
    pcap::UdpDatagram datagram{};
    for (std::size_t file = 0; keep_going && file < files_.size(); ++file) {
        if (file > 0) {
            stats_ += reader_->stats();
            reader_ = std::make_unique<pcap::PcapReader>(files_[file]);
        }
        while (keep_going && reader_->next(&datagram)) {
            capture_time_ns = datagram.timestamp_ns;
            const int routed =
                router_->route(datagram.src_ip, datagram.dst_port, datagram.data, datagram.size);
            if (routed < 0) continue;
            sensors_[static_cast<std::size_t>(routed)]->assembler->add_packet(datagram.data,
                                                                              datagram.size);
        }
        if (!reader_->warning().empty()) warning_ = reader_->warning();  // names the file
    }
    stats_ += reader_->stats();
    reader_.reset();
    for (auto& sensor : sensors_) {
        if (keep_going) sensor->assembler->flush();
    }
}

const ouster::AssemblyCounters& StationCapture::counters(std::size_t sensor) const {
    static const ouster::AssemblyCounters kNone{};
    for (const auto& s : sensors_) {
        if (s->index == sensor && s->assembler) return s->assembler->counters();
    }
    return kNone;
}

const ouster::RouterCounters& StationCapture::router_counters() const {
    return router_->counters();
}
pcap::PcapReaderStats StationCapture::pcap_stats() const {
    pcap::PcapReaderStats all = stats_;
    if (reader_) all += reader_->stats();
    return all;
}
const std::string& StationCapture::pcap_warning() const { return warning_; }

}  // namespace lidarfuse::capture

#include "drivers/sim/sim_outputs.hpp"

#include <fstream>
#include <memory>
#include <stdexcept>
#include <vector>

#include "drivers/pcap/pcap_writer.hpp"
#include "drivers/station/station_config.hpp"

namespace lidarfuse::sim {

namespace {

class PcapSink : public DatagramSink {
public:
    PcapSink(const std::filesystem::path& file, bool fragment)
        : writer_(file, make_options(fragment)) {}
    void write(const SimDatagram& d) override {
        writer_.write_udp(d.capture_ns, d.src_ip, d.src_port, d.dst_ip, d.dst_port,
                          d.payload.data(), d.payload.size());
    }
    void close() { writer_.close(); }

private:
    static pcap::PcapWriterOptions make_options(bool fragment) {
        pcap::PcapWriterOptions o;
        o.fragment = fragment;
        return o;
    }
    pcap::PcapWriter writer_;
};

void write_text(const std::filesystem::path& file, const std::string& text) {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) throw std::runtime_error("sim: cannot write " + file.string());
}

int stations(const Simulator& sim) { return sim.params().stations; }

std::filesystem::path station_dir(const Simulator& sim, const std::filesystem::path& dir,
                                  int station) {
    return stations(sim) == 1 ? dir : dir / ("station" + std::to_string(station));
}

std::string station_name(const Simulator& sim, const OutputOptions& options, int station) {
    const std::string name = options.station_name.empty()
                                 ? std::string("sim-") + to_string(sim.params().scenario)
                                 : options.station_name;
    return stations(sim) == 1 ? name : name + "-" + std::to_string(station);
}

// One station's metadata, station.yaml and ground truth: its sensors' rows of `truth`
// (Simulator::ground_truth(), each frame's rows in the order of the rigs).
void write_station(const Simulator& sim, const std::vector<io::PoseRecord>& truth,
                   const std::filesystem::path& dir, const std::string& name, int station) {
    std::filesystem::create_directories(dir);
    station::StationConfig config;
    config.station = name;
    for (const auto& rig : sim.rigs()) {
        if (rig.station() != station) continue;
        const auto json_file = dir / (rig.name() + ".json");
        write_text(json_file, ouster::to_nested_json(rig.info()));
        station::SensorConfig s;
        s.name = rig.name();
        s.udp_port = rig.lidar_port();
        s.metadata = std::filesystem::absolute(json_file).lexically_normal();
        config.sensors.push_back(s);
    }
    config.root = config.sensors.front().name;
    write_text(dir / "station.yaml",
               station::to_yaml(config, std::filesystem::absolute(dir).lexically_normal()));
    std::vector<io::PoseRecord> rows;
    for (std::size_t i = 0; i < truth.size(); ++i) {
        if (sim.rigs()[i % sim.rigs().size()].station() == station) rows.push_back(truth[i]);
    }
    io::write_pose_csv(dir / "ground_truth.csv", rows);
}

// Each datagram into its station's capture.
class StationPcapSinks : public DatagramSink {
public:
    StationPcapSinks(const Simulator& sim, const std::filesystem::path& dir, bool fragment)
        : sim_(sim) {
        for (int j = 0; j < stations(sim); ++j) {
            sinks_.push_back(
                std::make_unique<PcapSink>(station_dir(sim, dir, j) / "capture.pcap", fragment));
        }
    }
    void write(const SimDatagram& d) override {
        const int station = sim_.rigs()[static_cast<std::size_t>(d.sensor)].station();
        sinks_[static_cast<std::size_t>(station)]->write(d);
    }
    void close() {
        for (auto& sink : sinks_) sink->close();
    }

private:
    const Simulator& sim_;
    std::vector<std::unique_ptr<PcapSink>> sinks_;
};

}  // namespace

void write_description(const Simulator& sim, const std::filesystem::path& dir,
                       const OutputOptions& options) {
    const auto truth = sim.ground_truth();  // every sensor's, computed once
    for (int j = 0; j < stations(sim); ++j) {
        write_station(sim, truth, station_dir(sim, dir, j), station_name(sim, options, j), j);
    }
}

SimStats write_simulation(Simulator& sim, const std::filesystem::path& dir,
                          const OutputOptions& options) {
    write_description(sim, dir, options);
    StationPcapSinks sinks(sim, dir, options.fragment);
    const SimStats stats = sim.run(sinks);
    sinks.close();
    return stats;
}

}  // namespace lidarfuse::sim

#include "drivers/sim/sim_outputs.hpp"

#include <fstream>
#include <stdexcept>

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

}  // namespace

void write_description(const Simulator& sim, const std::filesystem::path& dir,
                       const OutputOptions& options) {
    std::filesystem::create_directories(dir);
    station::StationConfig station;
    station.station = options.station_name.empty()
                          ? std::string("sim-") + to_string(sim.params().scenario)
                          : options.station_name;
    for (const auto& rig : sim.rigs()) {
        const auto json_file = dir / (rig.name() + ".json");
        write_text(json_file, ouster::to_nested_json(rig.info()));
        station::SensorConfig s;
        s.name = rig.name();
        s.udp_port = rig.lidar_port();
        s.metadata = std::filesystem::absolute(json_file).lexically_normal();
        station.sensors.push_back(s);
    }
    station.root = sim.rigs().front().name();
    write_text(dir / "station.yaml",
               station::to_yaml(station, std::filesystem::absolute(dir).lexically_normal()));
    io::write_pose_csv(dir / "ground_truth.csv", sim.ground_truth());
}

SimStats write_simulation(Simulator& sim, const std::filesystem::path& dir,
                          const OutputOptions& options) {
    write_description(sim, dir, options);
    PcapSink sink(dir / "capture.pcap", options.fragment);
    const SimStats stats = sim.run(sink);
    sink.close();
    return stats;
}

}  // namespace lidarfuse::sim

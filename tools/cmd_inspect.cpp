// `lidarfuse inspect CAPTURE.pcap --meta M.json[@SRC_IP] [--meta ...] [--frames] [--digest]
//                   [--export FRAME_ID --out scan.ply [--sensor INDEX]]`
// Decodes a capture with the same router, assembler and projection as the daemon and
// prints, per sensor, `inspect_<sensor>_<name> value unit` summary lines; --frames adds one
// `scan ...` line per assembled frame, --digest the md5 of every field array of every
// frame in Ouster's digest convention as `frame <id> <FIELD> <md5> sensor <sensor>`.
#include <cinttypes>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/sensor_router.hpp"
#include "drivers/ouster/xyz_lut.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "tools/args.hpp"
#include "tools/command.hpp"
#include "tools/md5.hpp"
#include "tools/ply_writer.hpp"

namespace lidarfuse::tools {

namespace {

struct SensorState {
    std::string label;
    ouster::SensorInfo info;
    std::unique_ptr<ouster::ScanAssembler> assembler;
    std::uint64_t frames = 0;
    double completeness_sum = 0.0;
    double completeness_min = 1.0;
    bool have_capture_time = false;
    std::int64_t first_capture_ns = 0;
    std::int64_t last_capture_ns = 0;
    bool have_sensor_time = false;
    std::uint64_t first_sensor_ns = 0;
    std::uint64_t last_sensor_ns = 0;
};

struct ExportRequest {
    bool wanted = false;
    std::uint32_t frame_id = 0;
    int sensor = -1;  // -1: the first sensor (in --meta order) that has the frame
    std::string out;
    bool done = false;
    std::size_t vertices = 0;
    std::string sensor_label;
};

// "--meta FILE" or "--meta FILE@A.B.C.D" (a source address pins the sensor, see
// drivers/ouster/sensor_router.hpp).
ouster::RoutedSensor parse_meta_option(const std::string& value) {
    ouster::RoutedSensor s;
    std::string file = value;
    const auto at = value.rfind('@');
    if (at != std::string::npos) {
        file = value.substr(0, at);
        const std::string ip = value.substr(at + 1);
        unsigned a = 0, b = 0, c = 0, d = 0;
        char tail = 0;
        if (std::sscanf(ip.c_str(), "%u.%u.%u.%u%c", &a, &b, &c, &d, &tail) != 4 || a > 255 ||
            b > 255 || c > 255 || d > 255) {
            throw UsageError("--meta " + value + ": '" + ip + "' is not an IPv4 address");
        }
        s.source_ip = (a << 24) | (b << 16) | (c << 8) | d;
    }
    s.info = ouster::load_metadata(file);
    return s;
}

void record_frame(SensorState& s, const ouster::LidarScan& scan) {
    ++s.frames;
    s.completeness_sum += scan.completeness();
    if (scan.completeness() < s.completeness_min) s.completeness_min = scan.completeness();
    for (std::size_t c = 0; c < scan.columns(); ++c) {
        if (!scan.received[c]) continue;
        const std::uint64_t t = scan.timestamp_ns[c];
        if (!s.have_sensor_time || t < s.first_sensor_ns) s.first_sensor_ns = t;
        if (!s.have_sensor_time || t > s.last_sensor_ns) s.last_sensor_ns = t;
        s.have_sensor_time = true;
    }
}

void print_scan_line(const SensorState& s, const ouster::LidarScan& scan) {
    std::printf("scan frame %" PRIu32 " sensor %s packets %" PRIu32
                " received_columns %zu expected_columns %zu completeness %.6f %s\n",
                scan.frame_id, s.label.c_str(), scan.packets, scan.received_expected_columns(),
                scan.expected_columns(), scan.completeness(),
                scan.complete() ? "complete" : "incomplete");
}

void print_digest(const SensorState& s, const ouster::LidarScan& scan) {
    for (const auto& a : ouster::digest_arrays(scan)) {
        std::printf("frame %" PRIu32 " %s %s sensor %s\n", scan.frame_id, a.name,
                    md5_hex(a.data, a.bytes).c_str(), s.label.c_str());
    }
}

void export_scan(ExportRequest& request, const SensorState& s, const ouster::LidarScan& scan) {
    const ouster::XyzLut lut = ouster::make_xyz_lut(s.info);
    ouster::ScanCloud cloud;
    if (!ouster::project_scan(scan, lut, {}, &cloud)) {
        throw std::runtime_error("sensor " + s.label + ": the xyz table does not fit the scan");
    }
    write_ply(request.out, cloud.cloud.points,
              "lidarfuse frame " + std::to_string(scan.frame_id) + " sensor " + s.label +
                  " (Ouster sensor frame, metres)");
    request.done = true;
    request.vertices = cloud.cloud.size();
    request.sensor_label = s.label;
}

// The summary's lines are a format scripts read; the mode check's counters are not among them.
bool in_summary(const ouster::AssemblyCounterField& field) {
    return field.member != &ouster::AssemblyCounters::mode_mismatch_frames &&
           field.member != &ouster::AssemblyCounters::mode_mismatches;
}

void print_summary(const SensorState& s) {
    const auto& c = s.assembler->counters();
    const char* n = s.label.c_str();
    std::printf("inspect_%s_profile %s name\n", n, ouster::to_string(s.info.udp_profile_lidar));
    std::printf("inspect_%s_shape %dx%d pixels\n", n, s.info.pixels_per_column,
                s.info.columns_per_frame);
    for (const auto& field : ouster::kAssemblyCounterFields) {
        // Frames assembled by inspect itself, just before the assembler's frame counts.
        if (field.member == &ouster::AssemblyCounters::frames_complete)
            std::printf("inspect_%s_frames %" PRIu64 " frames\n", n, s.frames);
        if (!in_summary(field)) continue;
        std::printf("inspect_%s_%s %" PRIu64 " %s\n", n, field.name, c.*field.member, field.unit);
    }
    const double mean = s.frames ? s.completeness_sum / static_cast<double>(s.frames) : 0.0;
    std::printf("inspect_%s_completeness_mean %.6f ratio\n", n, mean);
    std::printf("inspect_%s_completeness_min %.6f ratio\n", n, s.frames ? s.completeness_min : 0.0);
    if (s.have_capture_time) {
        std::printf("inspect_%s_first_capture_time %" PRId64 " ns\n", n, s.first_capture_ns);
        std::printf("inspect_%s_last_capture_time %" PRId64 " ns\n", n, s.last_capture_ns);
    }
    if (s.have_sensor_time) {
        std::printf("inspect_%s_first_column_timestamp %" PRIu64 " ns\n", n, s.first_sensor_ns);
        std::printf("inspect_%s_last_column_timestamp %" PRIu64 " ns\n", n, s.last_sensor_ns);
    }
}

const char* const kUsage =
    "usage: lidarfuse inspect CAPTURE.pcap --meta M.json[@SRC_IP] [--meta ...]\n"
    "                         [--frames] [--digest]\n"
    "                         [--export FRAME_ID --out scan.ply [--sensor INDEX]]\n"
    "Assembles the Ouster packets of a capture per sensor and prints a summary as\n"
    "`inspect_<sensor>_<name> value unit` lines (<sensor> = serial number, or the\n"
    "--meta index when the metadata has none).\n"
    "  --frames   one `scan frame <id> sensor <s> ...` line per assembled frame\n"
    "  --digest   per frame and field `frame <id> <FIELD> <md5> sensor <s>` (md5 of the\n"
    "             staggered array in Ouster's digest convention)\n"
    "  --export   writes the xyz (sensor frame, metres; one vertex per pixel with a\n"
    "             return) of the frame with that frame_id as a binary PLY; --sensor\n"
    "             picks the --meta index when several sensors have that frame id\n"
    "Sensors sharing a port are told apart by header serial, packet size, and source\n"
    "address (learnt, or pinned with M.json@A.B.C.D; two LEGACY sensors of the same\n"
    "model need it).\n";

ExportRequest export_request(const Args& args, std::size_t num_metas) {
    ExportRequest request;
    if (const auto id = args.value("--export")) {
        request.wanted = true;
        request.frame_id = static_cast<std::uint32_t>(args.integer("--export", 0));
        request.out = args.required("--out");
        request.sensor = static_cast<int>(args.integer("--sensor", -1));
        if (request.sensor >= static_cast<int>(num_metas)) {
            throw UsageError("--sensor " + std::to_string(request.sensor) + ": only " +
                             std::to_string(num_metas) + " --meta given");
        }
    }
    return request;
}

// What inspect does with each frame a sensor's assembler emits. The request is shared by all
// sensors' handlers: the first matching frame is exported. Single-threaded (the read loop).
struct ScanHandler {
    SensorState* self;
    int index;  // --meta index
    ExportRequest* request;
    bool digest;
    bool frames;

    void operator()(const ouster::LidarScan& scan) const {
        record_frame(*self, scan);
        if (frames || digest) print_scan_line(*self, scan);
        if (digest) print_digest(*self, scan);
        if (request->wanted && !request->done && scan.frame_id == request->frame_id &&
            (request->sensor < 0 || request->sensor == index)) {
            export_scan(*request, *self, scan);
        }
    }
};

// One state per --meta, labelled by serial number (made unique), each with its assembler.
std::vector<std::unique_ptr<SensorState>> make_sensors(
    const std::vector<ouster::RoutedSensor>& routed, ExportRequest* request, bool digest,
    bool frames) {
    std::vector<std::unique_ptr<SensorState>> sensors;
    for (std::size_t i = 0; i < routed.size(); ++i) {
        auto s = std::make_unique<SensorState>();
        s->info = routed[i].info;
        s->label = s->info.prod_sn.empty() ? "sensor" + std::to_string(i) : s->info.prod_sn;
        for (std::size_t j = 0; j < i; ++j) {
            if (sensors[j]->label == s->label) s->label += "_" + std::to_string(i);
        }
        s->assembler = std::make_unique<ouster::ScanAssembler>(
            s->info, ouster::ScanAssemblerParams{},
            ScanHandler{s.get(), static_cast<int>(i), request, digest, frames});
        sensors.push_back(std::move(s));
    }
    return sensors;
}

// Routes every datagram of the capture to its sensor's assembler (capture times in ns).
void assemble_capture(pcap::PcapReader* reader, ouster::SensorRouter* router,
                      const std::vector<std::unique_ptr<SensorState>>& sensors) {
    pcap::UdpDatagram d;
    while (reader->next(&d)) {
        const int i = router->route(d.src_ip, d.dst_port, d.data, d.size);
        if (i == ouster::SensorRouter::kUnassigned) continue;
        SensorState& s = *sensors[static_cast<std::size_t>(i)];
        if (!s.have_capture_time) s.first_capture_ns = d.timestamp_ns;
        s.last_capture_ns = d.timestamp_ns;
        s.have_capture_time = true;
        s.assembler->add_packet(d.data, d.size);
    }
    for (auto& s : sensors) s->assembler->flush();
}

void print_capture_summary(const pcap::PcapReader& reader, const ouster::SensorRouter& router) {
    const auto& rs = reader.stats();
    std::printf("inspect_capture_records %" PRIu64 " records\n", rs.records);
    std::printf("inspect_capture_udp_datagrams %" PRIu64 " datagrams\n", rs.udp_datagrams);
    std::printf("inspect_capture_reassembled %" PRIu64 " datagrams\n", rs.reassembled);
    std::printf("inspect_capture_dropped_incomplete %" PRIu64 " datagrams\n",
                rs.dropped_incomplete);
    std::printf("inspect_capture_unassigned %" PRIu64 " datagrams\n", router.counters().unassigned);
}

// The export's lines, or why there is none (exit code 1).
int report_export(const ExportRequest& request, const std::string& capture_file) {
    if (!request.wanted) return 0;
    if (!request.done) {
        std::fprintf(
            stderr, "lidarfuse inspect: no frame with frame_id %" PRIu32 "%s in %s\n",
            request.frame_id,
            request.sensor >= 0 ? (" from sensor " + std::to_string(request.sensor)).c_str() : "",
            capture_file.c_str());
        return 1;
    }
    std::printf("export_frame %" PRIu32 " frame_id\n", request.frame_id);
    std::printf("export_sensor %s name\n", request.sensor_label.c_str());
    std::printf("export_vertices %zu points\n", request.vertices);
    std::fprintf(stderr, "wrote %s\n", request.out.c_str());
    return 0;
}

int run_inspect(int argc, char** argv) {
    const Args args(argc, argv, {"--meta", "--export", "--out", "--sensor"},
                    {"--digest", "--frames"});
    if (args.help() || args.positionals().size() != 1) {
        std::printf("%s", kUsage);
        return args.help() ? 0 : 2;
    }
    const auto metas = args.values("--meta");
    if (metas.empty()) throw UsageError("missing required option --meta");
    ExportRequest request = export_request(args, metas.size());
    const bool digest = args.flag("--digest");
    const bool frames = args.flag("--frames");

    std::vector<ouster::RoutedSensor> routed;
    for (const auto& m : metas) routed.push_back(parse_meta_option(m));
    ouster::SensorRouter router(routed);
    const auto sensors = make_sensors(routed, &request, digest, frames);

    pcap::PcapReader reader(args.positionals()[0]);
    assemble_capture(&reader, &router, sensors);
    print_capture_summary(reader, router);
    for (const auto& s : sensors) print_summary(*s);
    if (!reader.warning().empty()) std::fprintf(stderr, "warning: %s\n", reader.warning().c_str());
    return report_export(request, args.positionals()[0]);
}

}  // namespace

LIDARFUSE_REGISTER_COMMAND("inspect",
                           "decode an Ouster capture: per-sensor summary, digests, PLY export",
                           run_inspect);

}  // namespace lidarfuse::tools

// Builds the fuzzers' seed corpora from the sample captures at run time (nothing from the
// data folder is ever stored in the repository):
//   fuzz_seed_corpus DATA_DIR REPO_DIR OUT_DIR
// writes OUT_DIR/<harness>/ for every harness in this folder:
//   ouster_metadata   every metadata JSON of DATA_DIR, as is
//   ouster_packets    for every capture and each metadata file named after it, the first
//                     datagrams in fuzz_ouster_packets' input form (sensor description
//                     taken from the metadata)
//   pcap_reader       every capture cut after its first 12 records (written by libpcap)
//   ipv4_reassembler  the first 24 records' IPv4 fragments in fuzz_ipv4_reassembler's form
//   station_config    REPO_DIR/config/station.example.yaml and a station naming every
//                     metadata file of DATA_DIR (read with LIDARFUSE_FUZZ_BASE_DIR=DATA_DIR)
//   pcd_reader        every PCD under DATA_DIR/../real as is (libFuzzer reads the first
//                     -max_len bytes of the large ones), and each cut to 200 points from
//                     its middle: ascii ones as ascii, binary_compressed ones as
//                     binary_compressed and as binary, their fields and types kept
//   ply_reader        the first cut cloud written by io::write_ply in its three formats, and
//                     the ascii and little-endian ones with a face element (lists) after
//                     the vertices
//   sensor_http       every metadata JSON of DATA_DIR as one body, and each one that loads
//                     written by to_nested_json() as its parts joined by '\0' (forms 2/3)
//   point_cloud2      two layouts with their data: the daemon's fused cloud and a driver's
//                     (float64, big endian, padded rows)
// Prints one line per corpus with its number of files.
#include <pcap/pcap.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "drivers/io/cloud_file.hpp"
#include "drivers/io/cloud_lzf.hpp"
#include "drivers/io/cloud_pcd_header.hpp"
#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/sensor_http.hpp"
#include "drivers/pcap/frame_decoder.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "fuzz/fuzz_input.hpp"
#include "fuzz/packet_shapes.hpp"

namespace fs = std::filesystem;
namespace lf = lidarfuse;
namespace ouster = lidarfuse::ouster;
namespace fuzz = lidarfuse::fuzz;
namespace io = lidarfuse::io;

namespace {

void write_file(const fs::path& file, const std::string& bytes) {
    std::ofstream out(file, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) throw std::runtime_error("cannot write " + file.string());
}

std::string read_file(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

std::vector<fs::path> files_with(const fs::path& dir, const std::string& extension) {
    std::vector<fs::path> out;
    for (const auto& entry : fs::directory_iterator(dir)) {
        if (entry.is_regular_file() && entry.path().extension() == extension)
            out.push_back(entry.path());
    }
    std::sort(out.begin(), out.end());
    return out;
}

template <typename T, std::size_t N>
int index_of(const T (&table)[N], T value) {
    for (std::size_t i = 0; i < N; ++i) {
        if (table[i] == value) return static_cast<int>(i);
    }
    return -1;
}

// fuzz_ouster_packets' 16-byte sensor description (see that file), or empty when the
// metadata has a shape the harness cannot express.
std::string packet_header(const ouster::SensorInfo& info) {
    const int profile = index_of(fuzz::kPacketProfiles, info.udp_profile_lidar);
    const int columns = index_of(fuzz::kPacketColumns, info.columns_per_frame);
    const int rows = index_of(fuzz::kPacketRows, info.pixels_per_column);
    const int cpp = index_of(fuzz::kPacketColumnsPerPacket, info.columns_per_packet);
    if (profile < 0 || columns < 0 || rows < 0 || cpp < 0) return {};
    std::string h;
    h.push_back(static_cast<char>(profile | (1 << 3)));  // two frames in flight, CRC checked
    h.push_back(static_cast<char>(columns));
    h.push_back(static_cast<char>(rows));
    h.push_back(static_cast<char>(cpp));
    for (int v : info.column_window) {
        h.push_back(static_cast<char>(v & 0xFF));
        h.push_back(static_cast<char>(v >> 8));
    }
    const std::uint64_t serial = info.serial_number();
    for (int i = 0; i < 8; ++i) h.push_back(static_cast<char>((serial >> (8 * i)) & 0xFF));
    return h;
}

int packet_seeds(const fs::path& data_dir, const fs::path& out) {
    int written = 0;
    for (const auto& capture : files_with(data_dir, ".pcap")) {
        const std::string stem = capture.stem().string();
        for (const auto& json : files_with(data_dir, ".json")) {
            const std::string name = json.filename().string();
            if (name.find(stem) == std::string::npos || name.find("_digest") != std::string::npos)
                continue;
            ouster::SensorInfo info;
            try {
                info = ouster::load_metadata(json);
            } catch (const std::exception&) {
                continue;
            }
            const std::string header = packet_header(info);
            if (header.empty()) continue;
            // Datagrams of this sensor's size: lidar packets, and one IMU packet if any.
            lf::pcap::PcapReader reader(capture);
            lf::pcap::UdpDatagram d;
            std::string two = header, one = header, imu = header;
            int lidar = 0;
            bool have_imu = false;
            while (reader.next(&d) && (lidar < 2 || !have_imu) && reader.stats().records < 4000) {
                if (d.size == 48 && !have_imu) {
                    fuzz::append_record(&imu, d.data, d.size);
                    have_imu = true;
                } else if (d.size > 48 && lidar < 2) {
                    fuzz::append_record(&two, d.data, d.size);
                    if (lidar == 0) fuzz::append_record(&one, d.data, d.size);
                    ++lidar;
                }
            }
            if (lidar == 0) continue;
            const std::string base = json.stem().string();
            write_file(out / (base + ".1"), one);
            write_file(out / (base + ".2"), two);
            written += 2;
            if (have_imu) {
                write_file(out / (base + ".imu"), imu);
                ++written;
            }
        }
    }
    return written;
}

int pcap_seeds(const fs::path& data_dir, const fs::path& out) {
    int written = 0;
    for (const auto& capture : files_with(data_dir, ".pcap")) {
        char error[PCAP_ERRBUF_SIZE] = {};
        pcap_t* in = pcap_open_offline(capture.c_str(), error);
        if (!in) continue;
        const fs::path target = out / (capture.stem().string() + ".head.pcap");
        pcap_dumper_t* dumper = pcap_dump_open(in, target.c_str());
        if (!dumper) {
            pcap_close(in);
            throw std::runtime_error("cannot write " + target.string());
        }
        pcap_pkthdr* header = nullptr;
        const u_char* bytes = nullptr;
        for (int i = 0; i < 12 && pcap_next_ex(in, &header, &bytes) == 1; ++i) {
            pcap_dump(reinterpret_cast<u_char*>(dumper), header, bytes);
        }
        pcap_dump_close(dumper);
        pcap_close(in);
        ++written;
    }
    return written;
}

int reassembler_seeds(const fs::path& data_dir, const fs::path& out) {
    int written = 0;
    for (const auto& capture : files_with(data_dir, ".pcap")) {
        char error[PCAP_ERRBUF_SIZE] = {};
        pcap_t* in = pcap_open_offline(capture.c_str(), error);
        if (!in) continue;
        const int link = pcap_datalink(in);
        std::string seed(1, '\x03');  // table of four
        int fragments = 0;
        pcap_pkthdr* header = nullptr;
        const u_char* bytes = nullptr;
        for (int i = 0; i < 24 && pcap_next_ex(in, &header, &bytes) == 1; ++i) {
            lf::pcap::Ipv4Packet ip;
            if (lf::pcap::decode_frame(link, bytes, header->caplen, &ip) !=
                lf::pcap::FrameKind::kIpv4)
                continue;
            if (!ip.is_fragment()) continue;
            const std::uint8_t flags = static_cast<std::uint8_t>(
                (ip.more_fragments ? 1 : 0) | (ip.id & 3) << 3 | (ip.protocol == 17 ? 0x20 : 0));
            seed.push_back(static_cast<char>(flags));
            const std::uint32_t units = ip.offset_bytes / 8;
            seed.push_back(static_cast<char>(units & 0xFF));
            seed.push_back(static_cast<char>(units >> 8));
            fuzz::append_record(&seed, ip.payload, ip.payload_size);
            ++fragments;
        }
        pcap_close(in);
        if (fragments == 0) continue;
        write_file(out / (capture.stem().string() + ".fragments"), seed);
        ++written;
    }
    return written;
}

int config_seeds(const fs::path& data_dir, const fs::path& repo_dir, const fs::path& out) {
    int written = 0;
    const fs::path example = repo_dir / "config" / "station.example.yaml";
    if (fs::exists(example)) {
        fs::copy_file(example, out / "station.example.yaml", fs::copy_options::overwrite_existing);
        ++written;
    }
    std::ostringstream yaml;
    yaml << "station: samples\nroot: s0\nsensors:\n";
    int port = 7502, n = 0;
    for (const auto& json : files_with(data_dir, ".json")) {
        const std::string name = json.filename().string();
        if (name.find("_digest") != std::string::npos || name.find("crc_test") == 0) continue;
        yaml << "  - name: s" << n << "\n    udp_port: " << port << "\n    metadata: " << name
             << "\n";
        if (n % 2 == 1)
            yaml << "    source_address: 169.254.10." << (11 + n)
                 << "\n    time_offset_ns: -1500\n";
        ++n;
        port += 2;
    }
    yaml << "sync:\n  deadline_ms: 60\nhealth:\n  stale_after_ms: 300\n  lost_after_ms: 2500\n"
            "output:\n  directory: out\n  extrinsics_interval_frames: 10\n";
    write_file(out / "samples.yaml", yaml.str());
    return written + 1;
}

int metadata_seeds(const fs::path& data_dir, const fs::path& out) {
    int written = 0;
    for (const auto& json : files_with(data_dir, ".json")) {
        write_file(out / json.filename(), read_file(json));
        ++written;
    }
    return written;
}

// fuzz_sensor_http: each file as a form-1 body, and its nested form as the '\0'-separated
// parts of forms 2/3 in kMetadataParts' order (an absent part left empty).
int sensor_http_seeds(const fs::path& data_dir, const fs::path& out) {
    int written = 0;
    for (const auto& json : files_with(data_dir, ".json")) {
        write_file(out / json.filename(), read_file(json));
        ++written;
        ouster::SensorInfo info;
        try {
            info = ouster::load_metadata(json);
        } catch (const ouster::MetadataError&) {
            continue;
        }
        const nlohmann::json doc = nlohmann::json::parse(ouster::to_nested_json(info));
        std::string parts;
        for (std::size_t i = 0; i < ouster::kMetadataParts.size(); ++i) {
            if (i > 0) parts.push_back('\0');
            const char* name = ouster::kMetadataParts[i];
            if (doc.contains(name)) parts += doc[name].dump();
        }
        write_file(out / (json.stem().string() + ".parts"), parts);
        ++written;
    }
    return written;
}

// A PCD header's text with WIDTH, HEIGHT, POINTS and DATA rewritten for n unorganised points.
std::string resized_pcd_header(const std::string& header, std::size_t n, const std::string& data) {
    std::istringstream in(header);
    std::string line, out;
    while (std::getline(in, line)) {
        const std::string key = line.substr(0, line.find(' '));
        if (key == "WIDTH" || key == "POINTS") line = key + " " + std::to_string(n);
        if (key == "HEIGHT") line = "HEIGHT 1";
        if (key == "DATA") line = "DATA " + data;
        out += line + "\n";
    }
    return out;
}

// Rows [first, first + n) of an ascii PCD's data.
std::string ascii_rows(const std::string& bytes, const io::PcdHeader& h, std::size_t first,
                       std::size_t n) {
    std::size_t begin = h.data_offset;
    for (std::size_t i = 0; i < first; ++i) {
        const std::size_t newline = bytes.find('\n', begin);
        if (newline == std::string::npos) return {};
        begin = newline + 1;
    }
    std::size_t end = begin;
    for (std::size_t i = 0; i < n && end < bytes.size(); ++i) {
        const std::size_t newline = bytes.find('\n', end);
        end = newline == std::string::npos ? bytes.size() : newline + 1;
    }
    return bytes.substr(begin, end - begin);
}

// Points [first, first + n) of a binary_compressed PCD as its struct-of-arrays block.
std::string compressed_columns(const std::string& bytes, const io::PcdHeader& h, std::size_t first,
                               std::size_t n) {
    std::uint32_t sizes[2];
    std::memcpy(sizes, bytes.data() + h.data_offset, sizeof(sizes));  // little-endian host
    const std::string all =
        io::lzf_decompress_exact(bytes.data() + h.data_offset + 8, sizes[0], sizes[1], "seed");
    std::string out;
    for (const auto& f : h.fields) {
        const std::size_t width = f.type.size * f.count;
        out.append(all, h.points * f.offset + first * width, n * width);
    }
    return out;
}

// The same n points one after another (DATA binary).
std::string columns_to_records(const std::string& columns, const io::PcdHeader& h, std::size_t n) {
    std::string out(n * h.point_size, '\0');
    for (const auto& f : h.fields) {
        const std::size_t width = f.type.size * f.count;
        for (std::size_t i = 0; i < n; ++i) {
            std::memcpy(&out[i * h.point_size + f.offset], &columns[n * f.offset + i * width],
                        width);
        }
    }
    return out;
}

std::vector<fs::path> pcd_files(const fs::path& dir) {
    std::vector<fs::path> out;
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
        if (entry.is_regular_file() && entry.path().extension() == ".pcd")
            out.push_back(entry.path());
    }
    std::sort(out.begin(), out.end());
    return out;
}

// Writes the pcd_reader seeds; `*small` gets the first cut file's bytes.
int pcd_seeds(const fs::path& real_dir, const fs::path& out, std::string* small) {
    int written = 0;
    for (const auto& file : pcd_files(real_dir)) {
        const std::string bytes = read_file(file);
        const std::string stem =
            file.parent_path().filename().string() + "_" + file.stem().string();
        write_file(out / (stem + ".pcd"), bytes);
        const io::PcdHeader h = io::parse_pcd_header(bytes, file.string());
        // From the middle: organised Ouster clouds start with rows without a return.
        const std::size_t n = std::min<std::size_t>(h.points, 200), first = h.points / 2;
        const std::string header = bytes.substr(0, h.data_offset);
        std::string cut;
        if (h.data == io::PcdData::kAscii) {
            cut = resized_pcd_header(header, n, "ascii") + ascii_rows(bytes, h, first, n);
        } else if (h.data == io::PcdData::kBinaryCompressed) {
            const std::string columns = compressed_columns(bytes, h, first, n);
            const std::string lzf = io::lzf_compress_for_pcd(columns);
            const std::uint32_t sizes[2] = {static_cast<std::uint32_t>(lzf.size()),
                                            static_cast<std::uint32_t>(columns.size())};
            cut = resized_pcd_header(header, n, "binary_compressed") +
                  std::string(reinterpret_cast<const char*>(sizes), sizeof(sizes)) + lzf;
            write_file(out / (stem + ".cut.binary.pcd"),
                       resized_pcd_header(header, n, "binary") + columns_to_records(columns, h, n));
            ++written;
        }
        if (cut.empty()) continue;
        write_file(out / (stem + ".cut.pcd"), cut);
        if (small->empty()) *small = cut;
        written += 2;
    }
    return written;
}

// The cut cloud as PLY in every format, and two of them with a face element after the
// vertices (list properties to read past).
int ply_seeds(const std::string& small_pcd, const fs::path& out) {
    if (small_pcd.empty()) return 0;
    const io::CloudFile cloud = io::read_pcd(small_pcd, "seed.pcd");
    const std::pair<const char*, io::PlyEncoding> encodings[] = {
        {"ascii", io::PlyEncoding::kAscii},
        {"le", io::PlyEncoding::kBinaryLittleEndian},
        {"be", io::PlyEncoding::kBinaryBigEndian}};
    for (const auto& [name, encoding] : encodings)
        io::write_ply(out / (std::string(name) + ".ply"), cloud, encoding);
    const std::string faces =
        "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
    std::string ascii = read_file(out / "ascii.ply");
    ascii.replace(ascii.find("end_header\n"), 11, faces);
    write_file(out / "ascii_faces.ply", ascii + "3 0 1 2\n4 0 1 2 3\n");
    std::string le = read_file(out / "le.ply");
    le.replace(le.find("end_header\n"), 11, faces);
    for (const std::vector<int>& face : {std::vector<int>{0, 1, 2}, std::vector<int>{0, 1, 2, 3}}) {
        le.push_back(static_cast<char>(face.size()));
        for (int v : face) le.append(std::string(reinterpret_cast<const char*>(&v), 4));
    }
    write_file(out / "le_faces.ply", le);
    return 5;
}

// PointCloud2 layouts in fuzz_point_cloud2's form: the daemon's own (x, y, z, intensity
// float32, 20-byte points, one row) and a ROS driver's (2 rows, float64 z x y after a
// uint16 ring, big endian, padded rows), each with its data.
int point_cloud2_seeds(const fs::path& out) {
    const auto header = [](std::uint8_t height, std::uint16_t width, std::uint8_t step,
                           std::uint16_t row_step, bool big_endian) {
        std::string h;
        h.push_back(static_cast<char>(height));
        h.push_back(static_cast<char>(width & 0xFF));
        h.push_back(static_cast<char>(width >> 8));
        h.push_back(static_cast<char>(step));
        h.push_back(static_cast<char>(row_step & 0xFF));
        h.push_back(static_cast<char>(row_step >> 8));
        h.push_back(static_cast<char>(big_endian ? 1 : 0));
        return h;
    };
    // name index (x 0, y 1, z 2, intensity 3, ring 4), offset, datatype, count
    const auto field = [](int name, int offset, int datatype) {
        return std::string{static_cast<char>(name), static_cast<char>(offset),
                           static_cast<char>(datatype), 1};
    };
    std::string own = header(1, 8, 20, 160, false);
    own.push_back(4);
    own += field(0, 0, 7) + field(1, 4, 7) + field(2, 8, 7) + field(3, 12, 7);
    for (int i = 0; i < 8; ++i) {
        const float v[5] = {0.5f * static_cast<float>(i), -1.0f, 2.0f, 10.0f, 0.0f};
        own.append(reinterpret_cast<const char*>(v), 20);
    }
    write_file(out / "fused_float32", own);
    std::string driver = header(2, 3, 28, 96, true);
    driver.push_back(4);
    driver += field(4, 0, 4) + field(2, 2, 8) + field(0, 10, 8) + field(1, 18, 8);
    driver.append(std::string(2 * 96, '\x3f'));
    write_file(out / "driver_float64_big_endian", driver);
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: fuzz_seed_corpus DATA_DIR REPO_DIR OUT_DIR\n");
        return 2;
    }
    const fs::path data_dir = argv[1], repo_dir = argv[2], out = argv[3];
    if (!fs::is_directory(data_dir)) {
        std::fprintf(stderr, "fuzz_seed_corpus: no data folder %s\n", data_dir.c_str());
        return 1;
    }
    try {
        const auto dir = [&](const char* name) {
            const fs::path d = out / name;
            fs::create_directories(d);
            return d;
        };
        std::printf("seeds ouster_metadata %d\n", metadata_seeds(data_dir, dir("ouster_metadata")));
        std::printf("seeds ouster_packets %d\n", packet_seeds(data_dir, dir("ouster_packets")));
        std::printf("seeds pcap_reader %d\n", pcap_seeds(data_dir, dir("pcap_reader")));
        std::printf("seeds ipv4_reassembler %d\n",
                    reassembler_seeds(data_dir, dir("ipv4_reassembler")));
        std::printf("seeds station_config %d\n",
                    config_seeds(data_dir, repo_dir, dir("station_config")));
        // The real point clouds sit beside the Ouster samples: DATA_DIR/../real.
        const fs::path real_dir = data_dir / ".." / "real";
        std::string small_pcd;
        const int pcds =
            fs::is_directory(real_dir) ? pcd_seeds(real_dir, dir("pcd_reader"), &small_pcd) : 0;
        std::printf("seeds pcd_reader %d\n", pcds);
        std::printf("seeds ply_reader %d\n", ply_seeds(small_pcd, dir("ply_reader")));
        std::printf("seeds sensor_http %d\n", sensor_http_seeds(data_dir, dir("sensor_http")));
        std::printf("seeds point_cloud2 %d\n", point_cloud2_seeds(dir("point_cloud2")));
    } catch (const std::exception& error) {
        std::fprintf(stderr, "fuzz_seed_corpus: %s\n", error.what());
        return 1;
    }
    return 0;
}

// Ouster packet layouts: sizes, encode/decode round trips for every profile and row count,
// CRC-64 on known data and on real captures, header fields of the same-port captures, and
// the field arrays of the upstream digest files rebuilt straight from the packets.

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "drivers/ouster/packet_format.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::ouster {
namespace {

constexpr UdpProfileLidar kProfiles[] = {
    UdpProfileLidar::kLegacy, UdpProfileLidar::kRng19Rfl8Sig16Nir16,
    UdpProfileLidar::kRng15Rfl8Nir8, UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
    UdpProfileLidar::kFusaRng15Rfl8Nir8Dual};
constexpr Field kFields[] = {Field::kRange,   Field::kRange2,       Field::kSignal,
                             Field::kSignal2, Field::kReflectivity, Field::kReflectivity2,
                             Field::kNearIr};

struct Datagram {
    std::uint32_t src_ip;
    std::uint16_t dst_port;
    std::vector<std::uint8_t> bytes;
};

std::vector<Datagram> read_capture(const std::filesystem::path& path) {
    pcap::PcapReader reader(path);
    pcap::UdpDatagram d;
    std::vector<Datagram> out;
    while (reader.next(&d)) out.push_back({d.src_ip, d.dst_port, {d.data, d.data + d.size}});
    return out;
}

nlohmann::json read_json_file(const std::filesystem::path& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
}

TEST(OusterPacketFormat, SizesMatchTheCaptures) {
    EXPECT_EQ(PacketFormat(UdpProfileLidar::kLegacy, 64, 16).lidar_packet_size(), 12608u);
    EXPECT_EQ(PacketFormat(UdpProfileLidar::kLegacy, 32, 16).lidar_packet_size(), 6464u);
    EXPECT_EQ(PacketFormat(UdpProfileLidar::kLegacy, 128, 16).lidar_packet_size(), 24896u);
    EXPECT_EQ(PacketFormat(UdpProfileLidar::kRng19Rfl8Sig16Nir16, 128, 16).lidar_packet_size(),
              24832u);
    EXPECT_EQ(PacketFormat(UdpProfileLidar::kRng15Rfl8Nir8, 128, 16).lidar_packet_size(), 8448u);
    EXPECT_EQ(PacketFormat(UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual, 32, 16).lidar_packet_size(),
              8448u);
    EXPECT_EQ(PacketFormat(UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual, 64, 16).lidar_packet_size(),
              16640u);
    EXPECT_EQ(PacketFormat(UdpProfileLidar::kFusaRng15Rfl8Nir8Dual, 128, 16).lidar_packet_size(),
              16640u);
    EXPECT_EQ(PacketFormat(UdpProfileLidar::kLegacy, 64, 16).imu_packet_size(), 48u);
    EXPECT_THROW(PacketFormat(UdpProfileLidar::kLegacy, 0, 16), std::invalid_argument);
    EXPECT_THROW(PacketFormat(UdpProfileLidar::kLegacy, 64, 0), std::invalid_argument);
    // 128 rows x 64 columns of 12 B pixels does not fit in one datagram.
    EXPECT_THROW(PacketFormat(UdpProfileLidar::kLegacy, 128, 64), std::invalid_argument);
}

TEST(OusterPacketFormat, Crc64OfKnownData) {
    const std::string check = "123456789";
    EXPECT_EQ(crc64(reinterpret_cast<const std::uint8_t*>(check.data()), check.size()),
              0x995DC9BBDF1939FAULL);
    EXPECT_EQ(crc64(nullptr, 0), 0u);
    const std::uint8_t zeros[8] = {};
    EXPECT_NE(crc64(zeros, 8), crc64(zeros, 7));
}

TEST(OusterPacketFormat, FieldTableMatchesProfiles) {
    const PacketFormat legacy(UdpProfileLidar::kLegacy, 64, 16);
    EXPECT_FALSE(legacy.has_field(Field::kRange2));
    EXPECT_TRUE(legacy.has_field(Field::kSignal));
    const PacketFormat low(UdpProfileLidar::kRng15Rfl8Nir8, 64, 16);
    EXPECT_FALSE(low.has_field(Field::kSignal));
    EXPECT_EQ(low.spec(Field::kRange).upshift, 3);
    EXPECT_EQ(low.spec(Field::kNearIr).upshift, 4);
    const PacketFormat fusa(UdpProfileLidar::kFusaRng15Rfl8Nir8Dual, 128, 16);
    EXPECT_TRUE(fusa.has_field(Field::kRange2));
    EXPECT_TRUE(fusa.has_field(Field::kReflectivity2));
    EXPECT_FALSE(fusa.has_field(Field::kSignal2));
    EXPECT_EQ(fusa.header_type(), HeaderType::kFusa);
    // Hand-made RNG15 pixel: range 0x1234 (x8), reflectivity 0xAB, near_ir 0x0C (x16),
    // with the flag bit (bit 15) set, which must not leak into the range.
    std::vector<std::uint8_t> pkt(low.lidar_packet_size(), 0);
    std::uint8_t* px = low.pixel(low.column(pkt.data(), 3), 5);
    px[0] = 0x34;
    px[1] = 0x92;  // 0x12 | flag 0x80
    px[2] = 0xAB;
    px[3] = 0x0C;
    EXPECT_EQ(low.range_mm(px), 0x1234u * 8);
    EXPECT_EQ(low.reflectivity(px), 0xAB);
    EXPECT_EQ(low.near_ir(px), 0x0C * 16);
    EXPECT_EQ(low.signal(px), 0);
}

// Encodes random values with the write accessors and reads them back.
void round_trip(UdpProfileLidar profile, int rows, int columns, std::mt19937_64* rng) {
    const PacketFormat f(profile, rows, columns);
    SCOPED_TRACE(std::string(to_string(profile)) + " " + std::to_string(rows) + "x" +
                 std::to_string(columns));
    std::vector<std::uint8_t> pkt(f.lidar_packet_size());
    for (auto& b : pkt) b = static_cast<std::uint8_t>((*rng)());  // junk underneath
    const bool legacy = f.header_type() == HeaderType::kLegacy;
    const bool fusa = f.header_type() == HeaderType::kFusa;
    const std::uint32_t frame_id =
        static_cast<std::uint32_t>((*rng)() & (fusa ? 0xFFFFFFFFULL : 0xFFFFULL));
    const std::uint32_t init_id = static_cast<std::uint32_t>((*rng)() & 0xFFFFFF);
    const std::uint64_t serial = (*rng)() & 0xFFFFFFFFFFULL;
    const auto countdown = static_cast<std::uint8_t>((*rng)());
    const auto shot = static_cast<std::uint8_t>((*rng)() & 0x0F);
    const auto alerts = static_cast<std::uint8_t>((*rng)());
    f.set_packet_type(pkt.data(), PacketFormat::kLidarPacketType);
    f.set_frame_id(pkt.data(), frame_id);
    f.set_init_id(pkt.data(), init_id);
    f.set_prod_sn(pkt.data(), serial);
    f.set_countdown_thermal_shutdown(pkt.data(), countdown);
    f.set_shot_limiting(pkt.data(), shot);
    f.set_alert_flags(pkt.data(), alerts);

    struct Col {
        std::uint64_t ts;
        std::uint16_t mid;
        std::uint32_t status;
        std::uint32_t encoder;
    };
    std::vector<Col> cols(static_cast<std::size_t>(columns));
    std::vector<std::uint32_t> values(static_cast<std::size_t>(columns * rows * kFieldCount));
    for (int c = 0; c < columns; ++c) {
        Col& col = cols[static_cast<std::size_t>(c)];
        col = {(*rng)(), static_cast<std::uint16_t>((*rng)()),
               static_cast<std::uint32_t>((*rng)() & (legacy ? 0xFFFFFFFFULL : 0xFFFFULL)),
               static_cast<std::uint32_t>((*rng)())};
        std::uint8_t* cb = f.column(pkt.data(), c);
        f.set_column_timestamp_ns(cb, col.ts);
        f.set_column_measurement_id(cb, col.mid);
        f.set_column_status(cb, col.status);
        f.set_column_encoder_count(cb, col.encoder);
        for (int r = 0; r < rows; ++r) {
            std::uint8_t* px = f.pixel(cb, r);
            for (const Field fld : kFields) {
                const FieldSpec& s = f.spec(fld);
                const std::uint32_t v = static_cast<std::uint32_t>((*rng)() & s.mask) << s.upshift;
                values[static_cast<std::size_t>((c * rows + r) * kFieldCount +
                                                static_cast<int>(fld))] = v;
                EXPECT_EQ(f.set_field(px, fld, v), s.present());
            }
        }
    }
    if (legacy) f.set_frame_id(pkt.data(), frame_id);  // column headers hold it
    f.write_crc(pkt.data());

    EXPECT_EQ(f.classify(pkt.data(), pkt.size()), PacketKind::kLidar);
    EXPECT_EQ(f.frame_id(pkt.data()), legacy ? (frame_id & 0xFFFF) : frame_id);
    EXPECT_EQ(f.init_id(pkt.data()), legacy ? 0u : init_id);
    EXPECT_EQ(f.prod_sn(pkt.data()), legacy ? 0u : serial);
    EXPECT_EQ(f.packet_type(pkt.data()), legacy ? 0 : 1);
    EXPECT_EQ(f.countdown_thermal_shutdown(pkt.data()), legacy ? 0 : countdown);
    EXPECT_EQ(f.shot_limiting(pkt.data()), legacy ? 0 : shot);
    EXPECT_EQ(f.alert_flags(pkt.data()), legacy ? 0 : alerts);
    std::vector<std::uint32_t> column_values(static_cast<std::size_t>(rows));
    for (int c = 0; c < columns; ++c) {
        const Col& col = cols[static_cast<std::size_t>(c)];
        const std::uint8_t* cb = f.column(static_cast<const std::uint8_t*>(pkt.data()), c);
        EXPECT_EQ(f.column_timestamp_ns(cb), col.ts);
        EXPECT_EQ(f.column_measurement_id(cb), col.mid);
        EXPECT_EQ(f.column_status(cb), col.status);
        EXPECT_EQ(f.column_encoder_count(cb), legacy ? col.encoder : 0u);
        EXPECT_EQ(f.column_frame_id(cb), legacy ? (frame_id & 0xFFFF) : 0u);
        for (const Field fld : kFields) {
            f.read_column(cb, fld, column_values.data(), 1);
            for (int r = 0; r < rows; ++r) {
                const std::uint32_t expected = values[static_cast<std::size_t>(
                    (c * rows + r) * kFieldCount + static_cast<int>(fld))];
                const std::uint32_t got = f.field(f.pixel(cb, r), fld);
                if (got != expected ||
                    (f.has_field(fld) && column_values[static_cast<std::size_t>(r)] != expected)) {
                    ADD_FAILURE() << to_string(fld) << " col " << c << " row " << r << ": " << got
                                  << " != " << expected;
                    return;
                }
            }
        }
    }
    if (legacy) {
        EXPECT_EQ(f.check_crc(pkt.data()), CrcStatus::kNotApplicable);
    } else {
        EXPECT_EQ(f.check_crc(pkt.data()), CrcStatus::kValid);
        pkt[pkt.size() / 2] ^= 0x01;
        EXPECT_EQ(f.check_crc(pkt.data()), CrcStatus::kInvalid);
    }
}

TEST(OusterPacketFormat, EncodeDecodeRoundTripEveryProfile) {
    std::mt19937_64 rng(7);
    for (const UdpProfileLidar profile : kProfiles) {
        for (const int rows : {16, 32, 64, 128}) {
            for (const int columns : {1, 8, 16}) round_trip(profile, rows, columns, &rng);
        }
    }
}

TEST(OusterPacketFormat, ClassifyBySizeAndHeader) {
    const PacketFormat f(UdpProfileLidar::kRng19Rfl8Sig16Nir16, 64, 16);
    std::vector<std::uint8_t> pkt(f.lidar_packet_size(), 0);
    f.set_packet_type(pkt.data(), 1);
    EXPECT_EQ(f.classify(pkt.data(), pkt.size()), PacketKind::kLidar);
    EXPECT_EQ(f.classify(pkt.data(), 48), PacketKind::kImu);
    EXPECT_EQ(f.classify(pkt.data(), pkt.size() - 1), PacketKind::kWrongSize);
    EXPECT_EQ(f.classify(pkt.data(), 0), PacketKind::kWrongSize);
    f.set_packet_type(pkt.data(), 2);
    EXPECT_EQ(f.classify(pkt.data(), pkt.size()), PacketKind::kWrongProfile);
    PacketFormat with_serial = f;
    with_serial.set_expected_serial(122239000672ULL);
    f.set_packet_type(pkt.data(), 1);
    f.set_prod_sn(pkt.data(), 122239000673ULL);
    EXPECT_EQ(with_serial.classify(pkt.data(), pkt.size()), PacketKind::kWrongProfile);
    f.set_prod_sn(pkt.data(), 122239000672ULL);
    EXPECT_EQ(with_serial.classify(pkt.data(), pkt.size()), PacketKind::kLidar);
}

// Random packets of random sizes, and random content at the exact size: every accessor
// stays inside the buffer (ASan) and classify never claims a wrong-size buffer.
TEST(OusterPacketFormat, RandomPacketsNeverCrash) {
    std::mt19937_64 rng(99);
    int lidar = 0;
    for (int iter = 0; iter < 4000; ++iter) {
        const UdpProfileLidar profile = kProfiles[rng() % std::size(kProfiles)];
        const int rows = 16 << (rng() % 4);
        const PacketFormat f(profile, rows, 16);
        const bool exact = rng() % 2 == 0;
        const std::size_t size =
            exact ? f.lidar_packet_size() : rng() % (2 * f.lidar_packet_size());
        std::vector<std::uint8_t> buf(size);
        for (auto& b : buf) b = static_cast<std::uint8_t>(rng());
        if (exact && rng() % 2 == 0) f.set_packet_type(buf.data(), 1);
        const PacketKind kind = f.classify(buf.data(), buf.size());
        if (size != f.lidar_packet_size()) {
            EXPECT_NE(kind, PacketKind::kLidar);
            continue;
        }
        if (kind != PacketKind::kLidar) continue;
        ++lidar;
        std::uint64_t sink = f.frame_id(buf.data()) + f.init_id(buf.data()) + f.prod_sn(buf.data());
        for (int c = 0; c < f.columns_per_packet(); ++c) {
            const std::uint8_t* cb = f.column(static_cast<const std::uint8_t*>(buf.data()), c);
            sink += f.column_timestamp_ns(cb) + f.column_measurement_id(cb) + f.column_status(cb);
            for (int r = 0; r < rows; ++r) {
                for (const Field fld : kFields) sink += f.field(f.pixel(cb, r), fld);
            }
        }
        sink += static_cast<std::uint64_t>(f.check_crc(buf.data()));
        EXPECT_NE(sink, 1u);  // keeps the reads alive; the value is irrelevant
    }
    EXPECT_GT(lidar, 100);
}

// --- real captures ---

TEST(OusterPacketFormat, CrcTestCaptureHasValidFooters) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap_path, "crc_test.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta_path, "crc_test.json");
    const PacketFormat f(load_metadata(meta_path));
    std::map<std::uint32_t, int> frames;
    int imu = 0;
    for (const Datagram& d : read_capture(pcap_path)) {
        const PacketKind kind = f.classify(d.bytes.data(), d.bytes.size());
        if (kind == PacketKind::kImu) {
            ++imu;
            continue;
        }
        ASSERT_EQ(kind, PacketKind::kLidar);
        EXPECT_EQ(f.check_crc(d.bytes.data()), CrcStatus::kValid);
        EXPECT_EQ(f.prod_sn(d.bytes.data()), 122247000785ULL);
        EXPECT_EQ(f.init_id(d.bytes.data()), 11394290u);
        ++frames[f.frame_id(d.bytes.data())];
        // A single flipped bit anywhere is caught.
        std::vector<std::uint8_t> copy = d.bytes;
        copy[copy.size() / 3] ^= 0x10;
        EXPECT_EQ(f.check_crc(copy.data()), CrcStatus::kInvalid);
    }
    EXPECT_EQ(imu, 10);
    EXPECT_EQ(frames, (std::map<std::uint32_t, int>{{254, 32}, {255, 2}}));
}

TEST(OusterPacketFormat, SamePortCapturesAreToldApartByHeader) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap_path, "same_ports_nonlegacy.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(fusa_meta, "same_ports_nonlegacy.1.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(dual_meta, "same_ports_nonlegacy.2.json");
    const PacketFormat fusa(load_metadata(fusa_meta));
    const PacketFormat dual(load_metadata(dual_meta));
    ASSERT_EQ(fusa.lidar_packet_size(), 16640u);
    ASSERT_EQ(dual.lidar_packet_size(), 16640u);
    int fusa_packets = 0;
    int dual_packets = 0;
    int imu = 0;
    for (const Datagram& d : read_capture(pcap_path)) {
        const std::uint8_t* p = d.bytes.data();
        const PacketKind as_fusa = fusa.classify(p, d.bytes.size());
        const PacketKind as_dual = dual.classify(p, d.bytes.size());
        if (d.bytes.size() == 48) {
            EXPECT_EQ(as_fusa, PacketKind::kImu);
            ++imu;
            continue;
        }
        ASSERT_EQ(d.bytes.size(), 16640u);
        if (d.src_ip == 0xA9FEEE6Fu) {  // 169.254.238.111, OS-1-64-AH, RNG19 dual
            EXPECT_EQ(as_dual, PacketKind::kLidar);
            EXPECT_EQ(as_fusa, PacketKind::kWrongProfile);
            EXPECT_EQ(dual.frame_id(p), 1535u);
            EXPECT_EQ(dual.init_id(p), 9342165u);
            EXPECT_EQ(dual.prod_sn(p), 122239000672ULL);
            EXPECT_EQ(dual.check_crc(p), CrcStatus::kValid);
            EXPECT_EQ(dual.alert_flags(p), 0x8E);  // as captured
            // Column headers at the STANDARD offsets: 16 consecutive ids, all valid.
            const std::uint16_t first = dual.column_measurement_id(dual.column(p, 0));
            for (int c = 0; c < 16; ++c) {
                EXPECT_EQ(dual.column_measurement_id(dual.column(p, c)), first + c);
                EXPECT_TRUE(dual.column_valid(dual.column(p, c)));
            }
            ++dual_packets;
        } else {  // 169.254.92.158, OS-0-128, FUSA header
            EXPECT_EQ(as_fusa, PacketKind::kLidar);
            EXPECT_EQ(as_dual, PacketKind::kWrongProfile);
            EXPECT_EQ(fusa.packet_type(p), 1);
            EXPECT_EQ(fusa.init_id(p), 390078u);
            EXPECT_EQ(fusa.prod_sn(p), 122247000785ULL);
            EXPECT_EQ(fusa.frame_id(p), 1093u);
            EXPECT_EQ(fusa.check_crc(p), CrcStatus::kAbsent);
            EXPECT_EQ(fusa.alert_flags(p), 0xA7);  // as captured
            ++fusa_packets;
        }
    }
    EXPECT_EQ(fusa_packets, 1);
    EXPECT_EQ(dual_packets, 1);
    EXPECT_EQ(imu, 2);
}

TEST(OusterPacketFormat, FusaFrameIdIs32Bit) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap_path, "same_ports.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(fusa_meta, "same_ports.1.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(legacy_meta, "same_ports.2.json");
    const PacketFormat fusa(load_metadata(fusa_meta));
    const PacketFormat legacy(load_metadata(legacy_meta));
    std::vector<std::uint32_t> fusa_frames;
    std::vector<std::uint32_t> legacy_frames;
    for (const Datagram& d : read_capture(pcap_path)) {
        if (fusa.classify(d.bytes.data(), d.bytes.size()) == PacketKind::kLidar) {
            fusa_frames.push_back(fusa.frame_id(d.bytes.data()));
        }
        if (legacy.classify(d.bytes.data(), d.bytes.size()) == PacketKind::kLidar) {
            legacy_frames.push_back(legacy.frame_id(d.bytes.data()));
        }
    }
    EXPECT_EQ(fusa_frames, std::vector<std::uint32_t>{1542});
    EXPECT_EQ(legacy_frames, std::vector<std::uint32_t>{883});
}

// Rebuilds the staggered H x W field arrays straight from the packets (no assembler: one
// complete frame per capture) and compares them with Ouster's digest md5s.
void check_digest(const char* pcap_name, const char* meta_name, const char* digest_name) {
    const auto pcap_path = test::ouster_file(pcap_name);
    const auto meta_path = test::ouster_file(meta_name);
    const auto digest_path = test::ouster_file(digest_name);
    if (!pcap_path || !meta_path || !digest_path) GTEST_SKIP() << "sample data not found";
    const SensorInfo info = load_metadata(*meta_path);
    const PacketFormat f(info);
    const int h = info.pixels_per_column;
    const int w = info.columns_per_frame;
    const std::size_t n = static_cast<std::size_t>(h) * w;
    std::vector<std::uint32_t> range(n), range2(n);
    std::vector<std::uint16_t> signal(n), signal2(n), near_ir(n);
    std::vector<std::uint8_t> refl(n), refl2(n);
    std::vector<std::uint64_t> timestamp(static_cast<std::size_t>(w)),
        status(static_cast<std::size_t>(w));
    std::vector<std::uint16_t> mid(static_cast<std::size_t>(w));
    int packets = 0;
    for (const Datagram& d : read_capture(*pcap_path)) {
        if (f.classify(d.bytes.data(), d.bytes.size()) != PacketKind::kLidar) continue;
        ++packets;
        for (int c = 0; c < f.columns_per_packet(); ++c) {
            const std::uint8_t* cb = f.column(d.bytes.data(), c);
            const std::uint16_t m = f.column_measurement_id(cb);
            ASSERT_LT(m, w);
            timestamp[m] = f.column_timestamp_ns(cb);
            status[m] = f.column_status(cb);
            mid[m] = m;
            f.read_column(cb, Field::kRange, &range[m], w);
            f.read_column(cb, Field::kRange2, &range2[m], w);
            f.read_column(cb, Field::kSignal, &signal[m], w);
            f.read_column(cb, Field::kSignal2, &signal2[m], w);
            f.read_column(cb, Field::kNearIr, &near_ir[m], w);
            f.read_column(cb, Field::kReflectivity, &refl[m], w);
            f.read_column(cb, Field::kReflectivity2, &refl2[m], w);
        }
    }
    EXPECT_EQ(packets, w / f.columns_per_packet());
    const nlohmann::json digest = read_json_file(*digest_path);
    // Upstream digests list "scans"; the DERIVED reference calls them "frames".
    const nlohmann::json scan = digest.contains("scans") ? digest["scans"][0] : digest["frames"][0];
    auto md5 = [](const auto& v) { return test::md5_hex(v.data(), v.size() * sizeof(v[0])); };
    EXPECT_EQ(md5(timestamp), scan["TIMESTAMP"]);
    EXPECT_EQ(md5(status), scan["STATUS"]);
    EXPECT_EQ(md5(mid), scan["MEASUREMENT_ID"]);
    EXPECT_EQ(md5(range), scan["RANGE"]);
    EXPECT_EQ(md5(refl), scan["REFLECTIVITY"]);
    EXPECT_EQ(md5(near_ir), scan["NEAR_IR"]);
    if (scan.contains("SIGNAL")) {
        EXPECT_EQ(md5(signal), scan["SIGNAL"]);
    }
    if (scan.contains("RANGE2")) {
        EXPECT_EQ(md5(range2), scan["RANGE2"]);
    }
    if (scan.contains("SIGNAL2")) {
        EXPECT_EQ(md5(signal2), scan["SIGNAL2"]);
    }
    if (scan.contains("REFLECTIVITY2")) {
        EXPECT_EQ(md5(refl2), scan["REFLECTIVITY2"]);
    }
}

TEST(OusterPacketFormat, DigestLegacy) {
    check_digest("OS-1-32-G_v2.1.1_1024x10.pcap", "OS-1-32-G_v2.1.1_1024x10.json",
                 "OS-1-32-G_v2.1.1_1024x10_digest.json");
}
TEST(OusterPacketFormat, DigestRng19Single) {
    check_digest("OS-2-128-U1_v2.3.0_1024x10.pcap", "OS-2-128-U1_v2.3.0_1024x10.json",
                 "OS-2-128-U1_v2.3.0_1024x10_digest.json");
}
TEST(OusterPacketFormat, DigestRng15LowData) {
    check_digest("OS-0-128-U1_v2.3.0_1024x10.pcap", "OS-0-128-U1_v2.3.0_1024x10.json",
                 "OS-0-128-U1_v2.3.0_1024x10_digest.json");
}
TEST(OusterPacketFormat, DigestRng19Dual) {
    check_digest("OS-0-32-U1_v2.2.0_1024x10.pcap", "OS-0-32-U1_v2.2.0_1024x10.json",
                 "OS-0-32-U1_v2.2.0_1024x10_digest.json");
}
TEST(OusterPacketFormat, DigestLegacyGen1Derived) {
    // DERIVED reference (not upstream) for the FW 2.0 gen-1 capture and the reduced JSON.
    check_digest("OS-1-64_1024x10_fw20.pcap", "OS-1-64_sensor_config_reduced.json",
                 "DERIVED_OS-1-64_1024x10_fw20_reference.json");
}

}  // namespace
}  // namespace lidarfuse::ouster

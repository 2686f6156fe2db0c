// output.record's Recorder: what is offered comes back from the pcap files byte for byte,
// in order, with its addresses and receive times; files rotate by size and capture time;
// a disk running low removes the oldest file or stops the recording (both counted); a
// writer that cannot keep up drops datagrams (counted) instead of blocking the receivers;
// a folder that cannot be made is refused by name. The daemon end to end (a live run
// recorded, replayed into a second daemon): lidarfused_record_test.
#include "daemon/recorder.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/null_sink.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <atomic>
#include <condition_variable>
#include <csignal>
#include <fstream>
#include <mutex>
#include <thread>

#include "drivers/pcap/pcap_reader.hpp"
#include "drivers/pcap/replay.hpp"
#include "tests/daemon/dds_test_support.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr std::int64_t kT0 = 1'795'000'000'123'456'789;  // a receive time, ns since the epoch

std::shared_ptr<spdlog::logger> quiet_logger() {
    return std::make_shared<spdlog::logger>("record-test",
                                            std::make_shared<spdlog::sinks::null_sink_mt>());
}

// A station of two sensors whose config and metadata files exist (their text is irrelevant).
station::StationConfig station_in(const fs::path& dir) {
    std::ofstream(dir / "station.yaml") << "station: s\n";
    std::ofstream(dir / "a.json") << "{\"a\": 1}\n";
    std::ofstream(dir / "b.json") << "{\"b\": 2}\n";
    station::StationConfig st;
    st.source_file = dir / "station.yaml";
    st.sensors.resize(2);
    st.sensors[0].name = "a";
    st.sensors[0].metadata = dir / "a.json";
    st.sensors[1].name = "b";
    st.sensors[1].metadata = dir / "b.json";
    return st;
}

struct Sent {
    std::vector<std::uint8_t> payload;
    std::uint16_t port;
    std::int64_t t_ns;
};

// Datagram k: `size` bytes of a pattern of k, to port 7502 + 2 (k % 2), k x `step_ns` after kT0.
Sent datagram(std::size_t k, std::size_t size, std::int64_t step_ns) {
    Sent s{std::vector<std::uint8_t>(size), static_cast<std::uint16_t>(7502 + 2 * (k % 2)),
           kT0 + static_cast<std::int64_t>(k) * step_ns};
    for (std::size_t i = 0; i < size; ++i) s.payload[i] = static_cast<std::uint8_t>(k * 31 + i);
    return s;
}

void offer(daemon::Recorder* r, const Sent& s) {
    net::ReceivedDatagram d;
    d.local_port = s.port;
    d.src_ip = 0x0A000102u;  // 10.0.1.2
    d.src_port = 7502;
    d.receive_time_ns = s.t_ns;
    d.data = s.payload.data();
    d.size = s.payload.size();
    r->offer(d);
}

std::vector<pcap::UdpDatagram> read_all(const std::vector<fs::path>& files,
                                        std::vector<std::vector<std::uint8_t>>* payloads) {
    std::vector<pcap::UdpDatagram> out;
    for (const auto& f : files) {
        pcap::PcapReader reader(f);
        pcap::UdpDatagram d;
        while (reader.next(&d)) {
            out.push_back(d);
            payloads->emplace_back(d.data, d.data + d.size);
        }
        EXPECT_TRUE(reader.warning().empty()) << f << ": " << reader.warning();
    }
    return out;
}

daemon::RecordConfig config_in(const fs::path& dir) {
    daemon::RecordConfig c;
    c.enabled = true;
    c.directory = dir / "rec";
    c.min_free_mb = 0;
    c.queue_mb = 16;
    return c;
}

TEST(Recorder, WhatIsOfferedComesBackFromThePcapFilesInOrderWithTheSnapshotBeside) {
    test::TempDir dir("rec");
    std::vector<Sent> sent;
    fs::path folder;
    {
        daemon::Recorder r(config_in(dir.path()), station_in(dir.path()), 0x7F000001u,
                           quiet_logger());
        folder = r.folder();
        for (std::size_t k = 0; k < 300; ++k) {
            sent.push_back(datagram(k, 1000 + (k * 37) % 12000, 1'000'000));
            offer(&r, sent.back());
        }
        r.stop();
        const auto st = r.stats();
        EXPECT_EQ(st.datagrams, 300u);
        EXPECT_EQ(st.files, 1u);
        EXPECT_EQ(st.queue_drops, 0u);
        EXPECT_TRUE(st.recording);
        EXPECT_EQ(st.problem(), "");
    }
    EXPECT_EQ(folder.parent_path(), dir.path() / "rec");
    EXPECT_EQ(test::file_text(folder / "station.yaml"), "station: s\n");
    EXPECT_EQ(test::file_text(folder / "metadata" / "a.json"), "{\"a\": 1}\n");
    EXPECT_EQ(test::file_text(folder / "metadata" / "b.json"), "{\"b\": 2}\n");
    const auto files = pcap::capture_files(folder);
    ASSERT_EQ(files.size(), 1u);
    EXPECT_THAT(files[0].filename().string(), ::testing::StartsWith("00000-"));
    std::vector<std::vector<std::uint8_t>> payloads;
    const auto got = read_all(files, &payloads);
    ASSERT_EQ(got.size(), sent.size());
    for (std::size_t k = 0; k < sent.size(); ++k) {
        EXPECT_EQ(payloads[k], sent[k].payload) << k;
        EXPECT_EQ(got[k].dst_port, sent[k].port) << k;
        EXPECT_EQ(got[k].dst_ip, 0x7F000001u) << k;
        EXPECT_EQ(got[k].src_ip, 0x0A000102u) << k;
        EXPECT_EQ(got[k].src_port, 7502) << k;
        EXPECT_EQ(got[k].timestamp_ns, sent[k].t_ns) << k;  // nanosecond pcap
    }
}

TEST(Recorder, FilesRotateBySizeAndByCaptureTimeAndReadBackAsOneStream) {
    for (const bool by_time : {false, true}) {
        test::TempDir dir("rec");
        auto c = config_in(dir.path());
        c.max_file_mb = by_time ? 1000 : 1;  // 1 MiB: about 80 datagrams of 12.6 kB
        c.max_file_s = by_time ? 1 : 1000;   // 1 s: 20 datagrams 50 ms apart
        std::vector<Sent> sent;
        fs::path folder;
        {
            daemon::Recorder r(c, station_in(dir.path()), 0, quiet_logger());
            folder = r.folder();
            for (std::size_t k = 0; k < 250; ++k) {
                sent.push_back(datagram(k, 12608, 50'000'000));
                offer(&r, sent.back());
            }
            r.stop();
            EXPECT_EQ(r.stats().datagrams, 250u);
        }
        const auto files = pcap::capture_files(folder);
        // by size: 250 x 12.6 kB in 1 MiB files; by time: 12.5 s in 1 s files.
        EXPECT_EQ(files.size(), by_time ? 13u : 4u) << by_time;
        for (const auto& f : files) {
            if (!by_time) {
                EXPECT_LE(fs::file_size(f), 1024u * 1024u + 12608u + 100u) << f;
            }
        }
        std::vector<std::vector<std::uint8_t>> payloads;
        const auto got = read_all(files, &payloads);
        ASSERT_EQ(got.size(), sent.size()) << by_time;
        for (std::size_t k = 0; k < sent.size(); ++k) EXPECT_EQ(got[k].timestamp_ns, sent[k].t_ns);
    }
}

TEST(Recorder, LowDiskRemovesTheOldestFilesAndKeepsRecording) {
    test::TempDir dir("rec");
    auto c = config_in(dir.path());
    c.max_file_mb = 1;
    c.min_free_mb = 100;
    // A disk with room for three files of this recording.
    const auto free_space = [&](const fs::path& folder) -> std::uint64_t {
        std::uint64_t used = 0;
        std::error_code error;
        for (const auto& e : fs::directory_iterator(folder, error)) {
            if (e.path().extension() == ".pcap") used += e.file_size();
        }
        const std::uint64_t room = 100ull * 1024 * 1024 + 3ull * 1024 * 1024 + 512 * 1024;
        return used > room ? 0 : room - used;
    };
    fs::path folder;
    {
        daemon::Recorder r(c, station_in(dir.path()), 0, quiet_logger(), free_space);
        folder = r.folder();
        for (std::size_t k = 0; k < 800; ++k) offer(&r, datagram(k, 12608, 1'000'000));
        r.stop();
        const auto st = r.stats();
        EXPECT_TRUE(st.recording) << st.stopped_because;
        EXPECT_EQ(st.datagrams, 800u);
        EXPECT_GE(st.files, 10u);
        EXPECT_GE(st.files_removed, st.files - 4);
        EXPECT_THAT(st.problem(), HasSubstr("recording files removed for free disk space"));
    }
    const auto files = pcap::capture_files(folder);
    EXPECT_LE(files.size(), 4u);
    // The newest are kept: the last file holds the last datagram.
    std::vector<std::vector<std::uint8_t>> payloads;
    read_all({files.back()}, &payloads);
    ASSERT_FALSE(payloads.empty());
    EXPECT_EQ(payloads.back(), datagram(799, 12608, 1'000'000).payload);
}

TEST(Recorder, LowDiskWithStopPolicyStopsAndSaysWhy) {
    test::TempDir dir("rec");
    auto c = config_in(dir.path());
    c.min_free_mb = 100;
    c.when_disk_low = daemon::LowDiskPolicy::kStop;
    daemon::Recorder r(c, station_in(dir.path()), 0, quiet_logger(),
                       [](const fs::path&) -> std::uint64_t { return 10ull * 1024 * 1024; });
    ASSERT_TRUE(test::eventually([&] { return !r.stats().recording; }, 500));
    for (std::size_t k = 0; k < 10; ++k) offer(&r, datagram(k, 1000, 1'000'000));  // ignored
    r.stop();
    const auto st = r.stats();
    EXPECT_EQ(st.datagrams, 0u);
    EXPECT_THAT(
        st.problem(),
        HasSubstr("recording stopped: free disk space below output.record.min_free_mb (100 MB)"));
}

TEST(Recorder, AWriterThatCannotKeepUpDropsAndCountsInsteadOfBlocking) {
    test::TempDir dir("rec");
    auto c = config_in(dir.path());
    c.queue_mb = 1;
    c.min_free_mb = 1;
    // The writer's first free-space check blocks until the receivers have offered everything.
    std::mutex mutex;
    std::condition_variable released;
    bool release = false;
    std::atomic<bool> writer_blocked{false};
    const auto free_space = [&](const fs::path&) -> std::uint64_t {
        std::unique_lock<std::mutex> lock(mutex);
        writer_blocked = true;
        released.wait(lock, [&] { return release; });
        return 1ull << 40;
    };
    daemon::Recorder r(c, station_in(dir.path()), 0, quiet_logger(), free_space);
    ASSERT_TRUE(test::eventually([&] { return writer_blocked.load(); }, 500));
    std::vector<Sent> sent;
    for (std::size_t k = 0; k < 200; ++k) {
        sent.push_back(datagram(k, 12608, 1'000'000));
        offer(&r, sent.back());  // returns at once although nothing is written
    }
    {
        std::lock_guard<std::mutex> lock(mutex);
        release = true;
    }
    released.notify_all();
    r.stop();
    const auto st = r.stats();
    // 1 MiB holds 83 records of 12.6 kB; the rest are dropped, the kept ones are the first.
    EXPECT_EQ(st.datagrams, 83u);
    EXPECT_EQ(st.queue_drops, 117u);
    EXPECT_THAT(st.problem(), HasSubstr("117 datagrams not recorded"));
    std::vector<std::vector<std::uint8_t>> payloads;
    read_all(pcap::capture_files(r.folder()), &payloads);
    ASSERT_EQ(payloads.size(), 83u);
    for (std::size_t k = 0; k < payloads.size(); ++k) EXPECT_EQ(payloads[k], sent[k].payload);
}

TEST(Recorder, TheRingWrapsAroundWithoutCorruptingOrReorderingAnything) {
    // 1 MiB: wraps at its end; 32 MiB: also back to the start past its first 16 MiB.
    for (const double queue_mb : {1.0, 32.0}) {
        test::TempDir dir("rec");
        auto c = config_in(dir.path());
        c.queue_mb = queue_mb;
        std::vector<Sent> sent;
        fs::path folder;
        {
            daemon::Recorder r(c, station_in(dir.path()), 0, quiet_logger());
            folder = r.folder();
            // 37 MB as fast as it goes, in sizes that leave odd ends before the wraps: the writer
            // falls behind (drops), the ring wraps again and again.
            for (std::size_t k = 0; k < 8000; ++k) {
                sent.push_back(datagram(k, 100 + (k * 7919) % 9000, 1'000'000));
                offer(&r, sent.back());
            }
            r.stop();
            EXPECT_EQ(r.stats().datagrams + r.stats().queue_drops, sent.size());
            EXPECT_GT(r.stats().datagrams, 200u);
        }
        // What was written is what was offered, in order, byte for byte (drops only leave gaps).
        std::vector<std::vector<std::uint8_t>> payloads;
        read_all(pcap::capture_files(folder), &payloads);
        std::size_t k = 0;
        for (const auto& p : payloads) {
            while (k < sent.size() && sent[k].payload != p) ++k;
            ASSERT_LT(k, sent.size())
                << queue_mb << " MiB: a datagram written that was not offered, or out of order";
            ++k;
        }
    }
}

// The daemon's receivers offer from one thread per port at once.
TEST(Recorder, ReceiverThreadsOfferingAtOnceKeepEachPortsOrder) {
    test::TempDir dir("rec");
    auto c = config_in(dir.path());
    c.queue_mb = 4;
    constexpr std::size_t kPorts = 4, kEach = 1500;
    fs::path folder;
    daemon::RecorderStats st;
    {
        daemon::Recorder r(c, station_in(dir.path()), 0, quiet_logger());
        folder = r.folder();
        std::vector<std::thread> receivers;
        for (std::size_t port = 0; port < kPorts; ++port) {
            receivers.emplace_back([&r, port] {
                for (std::size_t k = 0; k < kEach; ++k) {
                    Sent s = datagram(k * kPorts + port, 200 + (k * 131) % 4000, 1000);
                    s.port = static_cast<std::uint16_t>(7000 + port);
                    offer(&r, s);
                }
            });
        }
        for (auto& t : receivers) t.join();
        r.stop();
        st = r.stats();
    }
    EXPECT_EQ(st.datagrams + st.queue_drops, kPorts * kEach);
    std::vector<std::vector<std::uint8_t>> payloads;
    const auto got = read_all(pcap::capture_files(folder), &payloads);
    ASSERT_EQ(got.size(), st.datagrams);
    std::vector<std::size_t> next(kPorts, 0);  // per port: the next k it may hold
    for (std::size_t i = 0; i < got.size(); ++i) {
        const std::size_t port = got[i].dst_port - 7000u;
        ASSERT_LT(port, kPorts);
        std::size_t k = next[port];
        while (k < kEach &&
               datagram(k * kPorts + port, 200 + (k * 131) % 4000, 1000).payload != payloads[i])
            ++k;
        ASSERT_LT(k, kEach) << "port " << port << ": not offered, or out of order";
        next[port] = k + 1;
    }
}

// A disk that fills up while recording: the file-size limit makes the writes fail as a
// full disk does (EFBIG instead of ENOSPC). The recording stops with the file named, what
// was written before stays readable, and nothing else stops.
TEST(Recorder, AWriteThatFailsStopsTheRecordingAndSaysWhy) {
    test::TempDir dir("rec");
    auto c = config_in(dir.path());
    rlimit before{};
    ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &before), 0);
    const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);  // the write fails instead
    rlimit small = before;
    small.rlim_cur = 3u << 20;  // 3 MiB per file
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
    daemon::RecorderStats st;
    fs::path folder;
    {
        daemon::Recorder r(c, station_in(dir.path()), 0, quiet_logger());
        folder = r.folder();
        for (std::size_t k = 0; k < 600; ++k) {  // 7.6 MB
            offer(&r, datagram(k, 12608, 1'000'000));
            if (k % 50 == 49)
                test::eventually(
                    [&] { return r.stats().datagrams + 1 > k || !r.stats().recording; }, 100);
        }
        r.stop();
        st = r.stats();
    }
    ::setrlimit(RLIMIT_FSIZE, &before);
    std::signal(SIGXFSZ, old_handler);
    EXPECT_FALSE(st.recording);
    EXPECT_GE(st.write_errors, 1u);
    EXPECT_THAT(st.problem(), HasSubstr("recording stopped: cannot write " + folder.string()));
    EXPECT_LT(st.datagrams, 600u);
    EXPECT_GT(st.datagrams, 100u);
    // What was written before is there, up to where the disk stopped it.
    const auto files = pcap::capture_files(folder);
    ASSERT_EQ(files.size(), 1u);
    pcap::PcapReader reader(files[0]);
    pcap::UdpDatagram d;
    std::size_t read = 0;
    while (reader.next(&d)) ++read;
    EXPECT_GT(read, 100u);
    EXPECT_LE(read, st.datagrams);
}

TEST(Recorder, AFolderThatCannotBeMadeIsRefusedByName) {
    test::TempDir dir("rec");
    std::ofstream(dir.path() / "file") << "x";
    auto c = config_in(dir.path());
    c.directory = dir.path() / "file" / "rec";
    try {
        daemon::Recorder r(c, station_in(dir.path()), 0, quiet_logger());
        FAIL() << "no error";
    } catch (const std::runtime_error& error) {
        EXPECT_THAT(error.what(), HasSubstr("output.record.directory: cannot create"));
        EXPECT_THAT(error.what(), HasSubstr((dir.path() / "file" / "rec").string()));
    }
}

TEST(CaptureFiles, AFileIsItselfAFolderItsPcapFilesInNameOrderElseAnError) {
    test::TempDir dir("rec");
    std::ofstream(dir.path() / "00001-b.pcap") << "";
    std::ofstream(dir.path() / "00000-z.pcap") << "";
    std::ofstream(dir.path() / "station.yaml") << "";
    const auto files = pcap::capture_files(dir.path());
    ASSERT_EQ(files.size(), 2u);
    EXPECT_EQ(files[0].filename(), "00000-z.pcap");
    EXPECT_EQ(files[1].filename(), "00001-b.pcap");
    EXPECT_EQ(pcap::capture_files(files[1]), std::vector<fs::path>{files[1]});
    EXPECT_THROW(pcap::capture_files(dir.path() / "none"), std::runtime_error);
    fs::create_directories(dir.path() / "empty");
    try {
        pcap::capture_files(dir.path() / "empty");
        FAIL() << "no error";
    } catch (const std::runtime_error& error) {
        EXPECT_THAT(error.what(), HasSubstr("without any .pcap file"));
    }
}

}  // namespace
}  // namespace lidarfuse

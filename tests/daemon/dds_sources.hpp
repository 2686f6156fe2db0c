#pragma once
// DDS sources for the daemon's tests (tests/daemon/dds_input_test.cpp,
// segment_tf_test.cpp): Cyclone writers that send the daemon's own cloud messages, a
// simulated station published as ROS 2 driver clouds, and a pipeline's figures once its
// readers and fusion have settled.

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <thread>

#include "daemon/dds_messages.hpp"
#include "daemon/pipeline.hpp"
#include "drivers/capture/station_capture.hpp"
#include "tests/daemon/dds_test_support.hpp"
#include "tests/daemon/lidarfused_test_support.hpp"

namespace lidarfuse::daemon::dds_sources {

namespace fs = std::filesystem;

// A writer per topic in one domain, sending the daemon's own cloud messages, whose frame
// is each cloud's `frame_id`.
class CloudWriters {
public:
    explicit CloudWriters(int domain)
        : participant_(
              dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr)) {}
    ~CloudWriters() { dds_delete(participant_); }
    bool ok() const { return participant_ > 0; }

    // Creates the topic's writer (before a reader should wait for it); false on failure.
    bool open(const std::string& topic) {
        if (writers_.count(topic)) return true;
        const dds_entity_t t = dds_create_topic(
            participant_, &sensor_msgs_msg_dds__PointCloud2__desc, topic.c_str(), nullptr, nullptr);
        if (t < 0) return false;
        dds_qos_t* qos = test::reader_qos(16);
        const dds_entity_t w = dds_create_writer(participant_, t, qos, nullptr);
        dds_delete_qos(qos);
        if (w < 0) return false;
        writers_.emplace(topic, w);
        return true;
    }
    bool write(const std::string& topic, const std::string& frame_id, const core::FusedCloud& c,
               std::int64_t stamp_ns) {
        if (!open(topic)) return false;
        FrameMessageBuilder builder({"test", frame_id, {"unused"}, 0});
        FrameStamps stamps;
        stamps.frame_ns = stamp_ns;
        return dds_write(writers_.at(topic), &builder.cloud(c, stamps)) == DDS_RETCODE_OK;
    }

private:
    dds_entity_t participant_;
    std::map<std::string, dds_entity_t> writers_;
};

// The pipeline's figures once each reader has made a scan of every cloud it took (a cloud is
// counted when taken, its scan after its points are copied: a snapshot between the two, slow
// under the sanitizers, differs by one) and fusion has stopped taking frames (or after 1 s).
inline PipelineStats settled_stats(Pipeline* pipeline) {
    std::uint64_t fused = 0;
    test::eventually(
        [&] {
            const PipelineStats now = pipeline->stats();
            bool settled = now.frames_fused == fused && now.frames_fused > 0;
            for (const auto& sensor : now.sensors)
                settled = settled && sensor.dds && sensor.scans == sensor.dds->clouds;
            fused = now.frames_fused;
            return settled;
        },
        1000);
    return pipeline->stats();
}

// A ROS 2 driver's view of a simulated station: each Ouster scan of `capture` as a
// PointCloud2 in its sensor's frame, stamped with the scan time, on its own topic, paced
// as captured. Returns the clouds written.
inline std::size_t publish_as_driver_clouds(const station::StationConfig& station,
                                            const fs::path& capture, const std::string& prefix,
                                            CloudWriters* writers) {
    capture::StationCapture scans(station, capture);
    std::size_t written = 0;
    std::int64_t first_capture_ns = 0;
    const auto start = std::chrono::steady_clock::now();
    scans.run([&](const capture::CaptureScan& scan) {
        if (first_capture_ns == 0) first_capture_ns = scan.capture_time_ns;
        std::this_thread::sleep_until(
            start + std::chrono::nanoseconds(scan.capture_time_ns - first_capture_ns));
        core::FusedCloud cloud;
        for (const auto& p : scan.cloud->cloud.points) {
            cloud.points.push_back(p.cast<float>());
            cloud.intensity.push_back(0.0f);
            cloud.sensor.push_back(0);
            cloud.dynamic.push_back(0);
        }
        const std::string& name = station.sensors[scan.sensor].name;
        if (writers->write(prefix + name + "/points", name, cloud, scan.t_ns)) ++written;
        return true;
    });
    return written;
}

// Two simulated sensors (5 s of lidarfused_test::simulate_two_sensors) that a test publishes
// as ROS 2 driver clouds, on rt/<tag><domain>/lidar<k>/points in a domain of this process.
class DriverTopics {
public:
    DriverTopics(const fs::path& dir, const std::string& tag)
        : sim_(dir / "sim"),
          domain_(test::unique_domain_id()),
          prefix_("rt/" + tag + std::to_string(domain_) + "/"),
          writers_(domain_) {}
    int domain() const { return domain_; }
    const fs::path& sim() const { return sim_; }

    // 5 s: the initial registration (about 1 s idle, 3 s and more under a parallel ctest) is
    // applied on the first frame after it finishes, so frames must still come then.
    void simulate() const { lidarfused_test::simulate_two_sensors(sim_, 5.0); }
    // The config's sensors: lidar0 and lidar1, each from its topic.
    std::string sensors_yaml() const {
        std::ostringstream yaml;
        for (const char* name : {"lidar0", "lidar1"}) {
            yaml << "  - {name: " << name << ", source: {dds: {topic: " << prefix_ << name
                 << "/points, domain_id: " << domain_ << "}}}\n";
        }
        return yaml.str();
    }
    // Opens the writers and waits until `pipeline`'s two inputs have matched them.
    void open_for(Pipeline* pipeline) {
        ASSERT_TRUE(writers_.ok());
        for (const char* name : {"lidar0", "lidar1"})
            ASSERT_TRUE(writers_.open(prefix_ + name + "/points"));
        ASSERT_TRUE(test::eventually([&] {
            const auto stats = pipeline->stats();
            return stats.sensors[0].dds->publishers > 0 && stats.sensors[1].dds->publishers > 0;
        }));
    }
    // Every scan of the capture, paced as captured; the clouds written.
    std::size_t publish() {
        const station::StationConfig sim_station =
            station::load_station_config(sim_ / "station.yaml");
        return publish_as_driver_clouds(sim_station, sim_ / "capture.pcap", prefix_, &writers_);
    }

private:
    fs::path sim_;
    int domain_;
    std::string prefix_;
    CloudWriters writers_;
};

}  // namespace lidarfuse::daemon::dds_sources

#pragma once
// station.yaml: which sensors a station has and where their data comes from. Shared by the
// simulator (which writes one), `lidarfuse calibrate/fuse` and lidarfused. The schema is
// documented in config/station.schema.md; parameters of later stages (sync, registration,
// outputs) live in their own sections, validated by their owners.
//
// Loading validates the whole file and throws ConfigError listing every problem with its
// key path (e.g. `sensors[2].udp_port: expected an integer in 1..65535, got "abc"`).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace lidarfuse::station {

// sensors[].configure: what lidarfused sets on a sensor named by hostname before using
// it (drivers/ouster/sensor_http.hpp), and sets again when the sensor comes back otherwise.
// udp_port_lidar is always the sensor's udp_port and operating_mode NORMAL.
struct SensorConfigure {
    bool enabled = false;
    std::optional<std::string> udp_dest;    // absent: this host's address on the way to the sensor
    std::optional<std::string> lidar_mode;  // "1024x20", ...; absent: left as it is
    std::optional<std::string> timestamp_mode;  // "TIME_FROM_PTP_1588", ...; absent: left
};

// sensors[].source: {dds: {topic, domain_id, frame_id}}: the sensor's scans are
// sensor_msgs/PointCloud2 clouds on a DDS topic (another station's fused cloud, or a ROS 2 LiDAR
// driver's), not Ouster packets. lidarfused only; the offline tools read Ouster captures.
struct DdsSource {
    std::string topic;  // the DDS topic name as on the wire, e.g. rt/station1/points
    int domain_id = 0;  // 0..232
    // The frame its clouds are in (others refused) and the sensor's tf frame, e.g. another
    // station's fused frame, so that that station's tree of tf frames hangs below this
    // daemon's. Absent: the first cloud's frame is kept, and the tf frame is the name.
    std::optional<std::string> frame_id;
};

struct SensorConfig {
    std::string name;            // unique; used in poses.csv, tf frames, logs
    std::uint16_t udp_port = 0;  // lidar data port (0 for a DDS source)
    // Where the data and its metadata come from: exactly one of a metadata file (absolute
    // after loading), the sensor's HTTP API at hostname:http_port (below; lidarfused only,
    // offline tools need a file) and a DDS source (`dds`, last; no metadata).
    std::filesystem::path metadata;             // Ouster metadata JSON
    std::optional<std::string> source_address;  // IPv4 dotted quad; tells apart shared ports
    std::int64_t time_offset_ns = 0;            // added to this sensor's timestamps
    bool enabled = true;
    std::optional<std::string> hostname;  // host name or IPv4 dotted quad
    int http_port = 80;
    SensorConfigure configure;  // only with hostname
    std::optional<DdsSource> dds;
};

struct StationConfig {
    std::string station = "station";
    std::string root;  // name of the root sensor (defaults to the first)
    std::vector<SensorConfig> sensors;
    std::filesystem::path source_file;  // where it was loaded from (empty if built in code)

    // Index of the root sensor in `sensors`.
    std::size_t root_index() const;
};

class ConfigError : public std::runtime_error {
public:
    ConfigError(const std::string& source, std::vector<std::string> problems);
    const std::vector<std::string>& problems() const { return problems_; }

private:
    std::vector<std::string> problems_;
};

// The whole text of a config file; ConfigError naming the file when it cannot be read.
std::string read_config_file(const std::filesystem::path& file);

// Parses and validates YAML text. Relative metadata paths resolve against `base_dir`.
StationConfig parse_station_config(const std::string& yaml_text, const std::string& source_name,
                                   const std::filesystem::path& base_dir);

// Loads a file; metadata paths resolve against the file's folder.
StationConfig load_station_config(const std::filesystem::path& file);

// Writes the station section as YAML (metadata paths written relative to `base_dir` when
// they lie below it). parse_station_config(to_yaml(c, d), ..., d) gives c back.
std::string to_yaml(const StationConfig& config, const std::filesystem::path& base_dir);

}  // namespace lidarfuse::station

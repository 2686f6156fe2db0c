#pragma once
// The sensor's HTTP API, as Ouster's firmware 2.x and 3.x document it: fetching the metadata
// of a sensor named by host (`sensors[].hostname`) and, optionally, configuring it.
//
// Metadata, first endpoint that answers 200 wins (older firmware lacks the newer ones):
//  1. GET /api/v1/sensor/metadata                      the whole document (FW >= 2.2)
//  2. GET /api/v1/sensor/metadata/<part>               one request per part (FW 2.x)
//  3. GET /api/v1/sensor/cmd/get_<part>                the same parts, FW 2.0 / 2.1
// where the parts are sensor_info, beam_intrinsics, imu_intrinsics, lidar_intrinsics,
// lidar_data_format and calibration_status, plus the active configuration from
// GET /api/v1/sensor/cmd/get_config_param?args=active; 2 and 3 are assembled into the
// nested document parse_metadata() reads. A 404 moves on to the next form; any other
// failure (time-out, refused connection, a status other than 200 or 404, a body over the
// size bound, JSON that does not parse or validate) is a SensorHttpError naming the host,
// the path and what was expected.
//
// Configuration: POST /api/v1/sensor/config?reinit=true&persist=false with a JSON object of
// the parameters to set, then GET /api/v1/sensor/metadata/sensor_info until its status is
// RUNNING (the sensor re-initialises: INITIALIZING for seconds, with a new init_id).
//
// The transport is cpp-httplib (Debian's libcpp-httplib-dev); every request has a connect
// and a read time-out and a bound on the body. Calls block the calling thread for at most
// the time-outs given; no state is shared between calls (thread safe).

#include <array>
#include <atomic>
#include <cstddef>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/ouster/metadata.hpp"

namespace lidarfuse::ouster {

struct SensorHttpParams {
    std::string host;  // host name or dotted quad, as configured
    int port = 80;
    double connect_timeout_s = 2.0;
    double read_timeout_s = 5.0;
    std::size_t max_body_bytes = 4u << 20;  // a full OS-2-128 document is ~100 kB
    std::string sensor_name;                // prefixes messages ("lidar0"); may be empty
};

// A request that failed: what was asked of whom, and why.
class SensorHttpError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct FetchedMetadata {
    std::string json;  // the document the info was parsed from (assembled for forms 2, 3)
    SensorInfo info;   // parsed and validated
    // The path of the form that answered: "/api/v1/sensor/metadata",
    // "/api/v1/sensor/metadata/<part>" or "/api/v1/sensor/cmd/get_<part>".
    std::string endpoint;
    std::string status;  // sensor_info.status ("RUNNING", "INITIALIZING", ...; "" if absent)
};

// Fetches, parses and validates the metadata (the forms above). Throws SensorHttpError.
FetchedMetadata fetch_metadata(const SensorHttpParams& params);

// The parameters lidarfused may set (`sensors[].configure`); unset ones are left alone.
struct SensorConfigRequest {
    std::optional<std::string> udp_dest;
    std::optional<int> udp_port_lidar;
    std::optional<std::string> lidar_mode;      // "1024x20", ...
    std::optional<std::string> timestamp_mode;  // "TIME_FROM_INTERNAL_OSC", ...
    std::optional<std::string> operating_mode;  // "NORMAL"
};

// The request's JSON object ({"udp_dest": "10.0.0.2", "udp_port_lidar": 7502, ...}).
std::string to_json(const SensorConfigRequest& request);

// Keys of `request` whose value differs from the active configuration in `info` (what a
// re-configuration would change); empty when the sensor already runs as asked.
std::vector<std::string> differing_config(const SensorConfigRequest& request,
                                          const SensorInfo& info);

// POSTs the request and waits up to `apply_timeout_s` for the sensor to be RUNNING again,
// or until `*cancel` is set (checked between polls: a daemon stopping). Throws
// SensorHttpError (refused parameters name the sensor's answer).
void configure_sensor(const SensorHttpParams& params, const SensorConfigRequest& request,
                      double apply_timeout_s, const std::atomic<bool>* cancel = nullptr);

// The parts of forms 2/3 as assemble_metadata_document() names them, in the order
// fuzz/fuzz_sensor_http.cpp assigns them. sensor_info, beam_intrinsics and
// lidar_data_format are required; "config_params" is the active configuration.
inline constexpr std::array<const char*, 7> kMetadataParts = {
    "sensor_info",       "beam_intrinsics",    "imu_intrinsics", "lidar_intrinsics",
    "lidar_data_format", "calibration_status", "config_params"};

// Pure parsing, without a network (fuzzed by fuzz/fuzz_sensor_http.cpp):
// - one response: `status` 200 and a body within the bound, else SensorHttpError naming
//   `what` (e.g. "os-122.local:80 GET /api/v1/sensor/metadata");
// - the parts of forms 2/3 ("sensor_info" -> its JSON body, ...; "config_params" -> the
//   active configuration) into one nested document; a part that is not a JSON object is a
//   SensorHttpError naming it;
// - a whole document into FetchedMetadata (MetadataError turned into SensorHttpError, with
//   every problem).
void check_response(int status, std::size_t body_bytes, std::size_t max_body_bytes,
                    const std::string& what);
std::string assemble_metadata_document(const std::map<std::string, std::string>& parts,
                                       const std::string& what);
FetchedMetadata parse_metadata_response(const std::string& body, const std::string& what);

}  // namespace lidarfuse::ouster

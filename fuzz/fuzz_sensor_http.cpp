// libFuzzer harness: the network-free half of the sensor HTTP client
// (drivers/ouster/sensor_http_response.cpp), i.e. what a sensor's answers go through.
//
// Input: split at '\0' bytes into up to 7 parts, assigned in order to kMetadataParts
// (sensor_info, beam_intrinsics, imu_intrinsics, lidar_intrinsics, lidar_data_format,
// calibration_status, config_params); the last part takes the rest, an empty part is
// absent (a 404). The parts are assembled as forms 2/3 are, the assembled document is
// parsed, and the whole input is parsed as one form-1 body.
//
// Contract checked besides memory safety (sensor_http.hpp): only SensorHttpError is
// thrown (anything else escapes and libFuzzer reports it), its message names `what`;
// what is accepted validates (validate_sensor_info empty) and reports sensor_info's status;
// an assembled document always holds the required parts.
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/sensor_http.hpp"
#include "fuzz/fuzz_input.hpp"

using namespace lidarfuse;

namespace {

constexpr const char* kWhat = "fuzz:80 GET /api/v1/sensor/metadata";

std::map<std::string, std::string> split_parts(const std::string& input) {
    std::map<std::string, std::string> parts;
    std::size_t begin = 0;
    for (std::size_t i = 0; i < ouster::kMetadataParts.size() && begin <= input.size(); ++i) {
        const bool last = i + 1 == ouster::kMetadataParts.size();
        const std::size_t end = last ? std::string::npos : input.find('\0', begin);
        const std::string part =
            input.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
        if (!part.empty()) parts[ouster::kMetadataParts[i]] = part;
        if (end == std::string::npos) break;
        begin = end + 1;
    }
    return parts;
}

// Parses `body`; an accepted document must validate and carry its status through.
void check_parse(const std::string& body) {
    ouster::FetchedMetadata got;
    try {
        got = ouster::parse_metadata_response(body, kWhat);
    } catch (const ouster::SensorHttpError& error) {
        if (std::string(error.what()).find(kWhat) == std::string::npos) {
            fuzz::invariant_failed("parse_metadata_response's error does not name `what`");
        }
        return;
    }
    if (!ouster::validate_sensor_info(got.info).empty()) {
        fuzz::invariant_failed("accepted metadata that validate_sensor_info rejects");
    }
    if (got.json != body || got.status != got.info.status || !got.endpoint.empty()) {
        fuzz::invariant_failed("FetchedMetadata does not hold the body and its status");
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string input(reinterpret_cast<const char*>(data), size);
    const std::map<std::string, std::string> parts = split_parts(input);
    try {
        const std::string document = ouster::assemble_metadata_document(parts, kWhat);
        for (const char* required : {"sensor_info", "beam_intrinsics", "lidar_data_format"}) {
            if (parts.count(required) == 0) fuzz::invariant_failed("a required part was absent");
        }
        check_parse(document);
    } catch (const ouster::SensorHttpError& error) {
        if (std::string(error.what()).find(kWhat) == std::string::npos) {
            fuzz::invariant_failed("assemble_metadata_document's error does not name `what`");
        }
    }
    check_parse(input);
    return 0;
}

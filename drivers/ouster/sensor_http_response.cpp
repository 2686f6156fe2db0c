// The network-free half of sensor_http.hpp: checking one answer, assembling the parts of
// forms 2/3 into the nested document, parsing a document, and the configuration request.
// No httplib here: fuzz/fuzz_sensor_http.cpp compiles this file alone.

#include <algorithm>
#include <nlohmann/json.hpp>

#include "drivers/ouster/sensor_http.hpp"

namespace lidarfuse::ouster {
namespace {

using nlohmann::json;

constexpr const char* kRequiredParts[] = {"sensor_info", "beam_intrinsics", "lidar_data_format"};

bool is_known_part(const std::string& name) {
    return std::find_if(kMetadataParts.begin(), kMetadataParts.end(),
                        [&](const char* p) { return name == p; }) != kMetadataParts.end();
}

// One part's body as a JSON object; anything else is a SensorHttpError naming the part.
json parse_part(const std::string& name, const std::string& text, const std::string& what) {
    json value;
    try {
        value = json::parse(text);
    } catch (const json::exception& e) {
        // parse_error, and out_of_range for numbers beyond a double.
        throw SensorHttpError(what + ": part " + name + " is not JSON: " + e.what());
    }
    if (!value.is_object()) {
        throw SensorHttpError(what + ": part " + name + " is not a JSON object");
    }
    return value;
}

}  // namespace

void check_response(int status, std::size_t body_bytes, std::size_t max_body_bytes,
                    const std::string& what) {
    if (status != 200) {
        throw SensorHttpError(what + ": HTTP " + std::to_string(status) + ", expected 200");
    }
    if (body_bytes > max_body_bytes) {
        throw SensorHttpError(what + ": body of " + std::to_string(body_bytes) + " bytes, over " +
                              std::to_string(max_body_bytes) + " bytes");
    }
}

std::string assemble_metadata_document(const std::map<std::string, std::string>& parts,
                                       const std::string& what) {
    json doc = json::object();
    for (const auto& [name, text] : parts) {
        if (!is_known_part(name)) throw SensorHttpError(what + ": unknown part " + name);
        doc[name] = parse_part(name, text, what);
    }
    for (const char* name : kRequiredParts) {
        if (!doc.contains(name)) throw SensorHttpError(what + ": part " + name + " is missing");
    }
    // The parser validated the strings' UTF-8, so dump() cannot throw; `replace` keeps
    // that true should it ever not.
    return doc.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

FetchedMetadata parse_metadata_response(const std::string& body, const std::string& what) {
    FetchedMetadata out;
    try {
        out.info = parse_metadata(body, what);
    } catch (const MetadataError& e) {
        // e.what() names `what` and lists every problem, one per line.
        throw SensorHttpError(e.what());
    }
    out.json = body;
    // parse_metadata reads sensor_info.status (nested) or the top-level status (legacy
    // flat) into info.status, and leaves it empty when absent.
    out.status = out.info.status;
    return out;
}

std::string to_json(const SensorConfigRequest& request) {
    json j = json::object();
    if (request.udp_dest) j["udp_dest"] = *request.udp_dest;
    if (request.udp_port_lidar) j["udp_port_lidar"] = *request.udp_port_lidar;
    if (request.lidar_mode) j["lidar_mode"] = *request.lidar_mode;
    if (request.timestamp_mode) j["timestamp_mode"] = *request.timestamp_mode;
    if (request.operating_mode) j["operating_mode"] = *request.operating_mode;
    // Invalid UTF-8 in a configured string becomes U+FFFD instead of an exception; the
    // sensor then refuses the value, naming it.
    return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::vector<std::string> differing_config(const SensorConfigRequest& request,
                                          const SensorInfo& info) {
    std::vector<std::string> keys;
    if (request.udp_dest && *request.udp_dest != info.udp_dest) keys.push_back("udp_dest");
    if (request.udp_port_lidar && *request.udp_port_lidar != info.udp_port_lidar) {
        keys.push_back("udp_port_lidar");
    }
    if (request.lidar_mode && *request.lidar_mode != info.lidar_mode) {
        keys.push_back("lidar_mode");
    }
    if (request.timestamp_mode && *request.timestamp_mode != info.timestamp_mode) {
        keys.push_back("timestamp_mode");
    }
    // operating_mode is not compared: SensorInfo does not carry it. A sensor in STANDBY
    // sends no packets, which the daemon sees as a LOST sensor rather than through its
    // metadata.
    return keys;
}

}  // namespace lidarfuse::ouster

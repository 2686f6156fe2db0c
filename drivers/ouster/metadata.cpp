// Metadata JSON parsing: locate every key for the document's form, read it with type
// checks (collecting problems with their JSON paths), apply Ouster's defaults for absent
// keys, then run the semantic checks shared with validate_sensor_info().

#include "drivers/ouster/metadata.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "drivers/ouster/metadata_checks.hpp"
#include "drivers/ouster/metadata_json_reader.hpp"

namespace lidarfuse::ouster {
namespace {

using detail::Reader;
using detail::show;
using detail::type_name;
using nlohmann::json;

std::string join_problems(const std::string& source, const std::vector<std::string>& problems) {
    std::ostringstream out;
    out << source << ": invalid Ouster metadata (" << problems.size() << " problem"
        << (problems.size() == 1 ? "" : "s") << ")";
    for (const std::string& p : problems) out << "\n  " << p;
    return out.str();
}

// Where each logical key lives in either document form.
detail::MetadataPaths paths_for(MetadataForm form) {
    detail::MetadataPaths p;
    if (form == MetadataForm::kNested) {
        p.sensor = "sensor_info.";
        p.beam = "beam_intrinsics.";
        p.format = "lidar_data_format.";
        p.config = "config_params.";
        p.lidar_to_sensor = "lidar_intrinsics.lidar_to_sensor_transform";
        p.imu_to_sensor = "imu_intrinsics.imu_to_sensor_transform";
    } else {
        p.format = "data_format.";
        p.lidar_to_sensor = "lidar_to_sensor_transform";
        p.imu_to_sensor = "imu_to_sensor_transform";
    }
    return p;
}

constexpr const char* kNestedSections[] = {"sensor_info",       "beam_intrinsics",
                                           "lidar_intrinsics",  "imu_intrinsics",
                                           "lidar_data_format", "config_params"};

// Nested when any of its sections is present, else legacy flat. Reports sections that are
// not objects, and the two sections the nested form cannot do without.
MetadataForm read_form(const json& root, Reader& r) {
    int nested_sections = 0;
    for (const char* s : kNestedSections) {
        if (root.contains(s)) {
            ++nested_sections;
            if (!root[s].is_object()) r.problem(s, "expected an object, got " + type_name(root[s]));
        }
    }
    const MetadataForm form =
        nested_sections > 0 ? MetadataForm::kNested : MetadataForm::kLegacyFlat;
    if (form == MetadataForm::kNested) {
        for (const char* s : {"sensor_info", "beam_intrinsics"}) {
            if (!root.contains(s)) r.problem(s, "missing (required in the nested form)");
        }
    }
    return form;
}

// True when `path` is absent; the caller then applies Ouster's default, so the key is
// listed in info.defaults_applied.
bool absent(const Reader& r, const std::string& path, SensorInfo& info) {
    if (!r.has(path)) info.defaults_applied.push_back(path);
    return !r.has(path);
}

// sensor_info: serial, product, firmware, status, initialization id.
void read_identity(Reader& r, const detail::MetadataPaths& p, SensorInfo& info) {
    r.string_or_integer(p.sensor + "prod_sn", &info.prod_sn);
    r.string(p.sensor + "prod_line", &info.prod_line);
    r.string(p.sensor + "prod_pn", &info.prod_pn);
    r.string(p.sensor + "build_rev", &info.build_rev);
    r.string(p.sensor + "image_rev", &info.image_rev);
    r.string(p.sensor + "status", &info.status);
    r.integer_as(p.sensor + "initialization_id", 0, 0xFFFFFF, &info.init_id);
}

// Columns and frame rate: lidar_mode, else columns_per_frame (+ fps) from the data format;
// when both are given they must agree.
void read_mode(Reader& r, const detail::MetadataPaths& p, SensorInfo& info) {
    const bool have_mode = r.string(p.config + "lidar_mode", &info.lidar_mode);
    std::optional<std::array<int, 2>> mode;
    if (have_mode) {
        mode = parse_lidar_mode(info.lidar_mode);
        if (!mode) {
            r.problem(p.config + "lidar_mode",
                      "unknown mode \"" + info.lidar_mode +
                          "\" (expected 512x10, 512x20, 1024x10, 1024x20, 2048x10 or 4096x5)");
        }
    } else if (!r.has(p.config + "lidar_mode") && !r.has(p.format + "columns_per_frame")) {
        r.problem(p.config + "lidar_mode",
                  "missing (and no " + p.format + "columns_per_frame either)");
    }
    if (mode) {
        info.columns_per_frame = (*mode)[0];
        info.frames_per_second = (*mode)[1];
    }
    int cpf = 0;
    if (r.integer_as(p.format + "columns_per_frame", 1, 65535, &cpf)) {
        if (mode && cpf != (*mode)[0]) {
            r.problem(p.format + "columns_per_frame", std::to_string(cpf) + " contradicts " +
                                                          p.config + "lidar_mode \"" +
                                                          info.lidar_mode + "\"");
        }
        info.columns_per_frame = cpf;
        if (!have_mode) info.lidar_mode.clear();
    }
    int fps = 0;
    if (r.integer_as(p.format + "fps", 1, 1000, &fps)) {
        if (mode && fps != (*mode)[1]) {
            r.problem(p.format + "fps", std::to_string(fps) + " contradicts " + p.config +
                                            "lidar_mode \"" + info.lidar_mode + "\"");
        }
        info.frames_per_second = fps;
    }
    if (!have_mode && info.lidar_mode.empty() && cpf > 0) {
        info.lidar_mode = std::to_string(cpf) + "x" + std::to_string(info.frames_per_second);
        if (!parse_lidar_mode(info.lidar_mode)) info.lidar_mode.clear();
    }
}

// beam_intrinsics: altitude and azimuth angle per beam in degrees (required, no default).
void read_beam_angles(Reader& r, const detail::MetadataPaths& p, SensorInfo& info) {
    if (!r.numbers(p.beam + "beam_altitude_angles", &info.beam_altitude_angles_deg) &&
        !r.has(p.beam + "beam_altitude_angles")) {
        r.problem(p.beam + "beam_altitude_angles", "missing");
    }
    if (!r.numbers(p.beam + "beam_azimuth_angles", &info.beam_azimuth_angles_deg) &&
        !r.has(p.beam + "beam_azimuth_angles")) {
        r.problem(p.beam + "beam_azimuth_angles", "missing");
    }
}

// Rows per column and columns per UDP packet. The nested form may give columns_per_packet
// in config_params as well; the two must agree.
void read_packet_layout(Reader& r, const detail::MetadataPaths& p, SensorInfo& info) {
    if (absent(r, p.format + "pixels_per_column", info)) {
        info.pixels_per_column = static_cast<int>(info.beam_altitude_angles_deg.size());
    } else {
        r.integer_as(p.format + "pixels_per_column", 1, 4096, &info.pixels_per_column);
    }
    const bool cpp_in_format = r.has(p.format + "columns_per_packet");
    const bool cpp_in_config =
        info.form == MetadataForm::kNested && r.has(p.config + "columns_per_packet");
    if (!cpp_in_format && !cpp_in_config) {
        info.defaults_applied.push_back(p.format + "columns_per_packet");
    }
    int cpp_config = 0;
    if (cpp_in_config) {
        r.integer_as(p.config + "columns_per_packet", 1, 65535, &cpp_config);
        info.columns_per_packet = cpp_config > 0 ? cpp_config : info.columns_per_packet;
    }
    if (cpp_in_format &&
        r.integer_as(p.format + "columns_per_packet", 1, 65535, &info.columns_per_packet) &&
        cpp_config > 0 && cpp_config != info.columns_per_packet) {
        r.problem(p.format + "columns_per_packet",
                  std::to_string(info.columns_per_packet) + " contradicts " + p.config +
                      "columns_per_packet " + std::to_string(cpp_config));
    }
}

bool read_lidar_profile(Reader& r, const std::string& path, UdpProfileLidar* out) {
    std::string name;
    if (!r.string(path, &name)) return false;
    const auto prof = udp_profile_lidar_from_string(name);
    if (!prof) {
        r.problem(path, "unknown UDP lidar profile \"" + name + "\"");
        return false;
    }
    *out = *prof;
    return true;
}

// UDP lidar and IMU packet profiles, from the data format or (nested form) config_params;
// when both give the lidar profile they must agree.
void read_udp_profiles(Reader& r, const detail::MetadataPaths& p, SensorInfo& info) {
    UdpProfileLidar prof_format = UdpProfileLidar::kLegacy;
    UdpProfileLidar prof_config = UdpProfileLidar::kLegacy;
    const bool have_prof_format =
        read_lidar_profile(r, p.format + "udp_profile_lidar", &prof_format);
    const bool have_prof_config =
        info.form == MetadataForm::kNested &&
        read_lidar_profile(r, p.config + "udp_profile_lidar", &prof_config);
    if (have_prof_format && have_prof_config && prof_format != prof_config) {
        r.problem(p.format + "udp_profile_lidar",
                  std::string(to_string(prof_format)) + " contradicts " + p.config +
                      "udp_profile_lidar " + to_string(prof_config));
    }
    info.udp_profile_lidar = have_prof_format   ? prof_format
                             : have_prof_config ? prof_config
                                                : UdpProfileLidar::kLegacy;
    if (!r.has(p.format + "udp_profile_lidar") && !r.has(p.config + "udp_profile_lidar")) {
        info.defaults_applied.push_back(p.format + "udp_profile_lidar");
    }
    std::string imu_name;
    if (r.string(p.format + "udp_profile_imu", &imu_name) ||
        (info.form == MetadataForm::kNested && r.string(p.config + "udp_profile_imu", &imu_name))) {
        const auto imu = udp_profile_imu_from_string(imu_name);
        if (!imu) {
            r.problem(p.format + "udp_profile_imu", "unknown UDP IMU profile \"" + imu_name + "\"");
        } else {
            info.udp_profile_imu = *imu;
        }
    }
}

// Which measurement ids the sensor fills, and each row's stagger in columns. Runs after
// the mode and the beam angles, whose values the defaults are built from.
void read_column_layout(Reader& r, const detail::MetadataPaths& p, SensorInfo& info) {
    if (absent(r, p.format + "column_window", info)) {
        info.column_window = {0, info.columns_per_frame - 1};
    } else {
        std::vector<int> w;
        if (r.integers(p.format + "column_window", 0, 65535, &w)) {
            if (w.size() != 2) {
                r.problem(p.format + "column_window",
                          "expected 2 integers [first, last], got " + std::to_string(w.size()));
            } else {
                info.column_window = {w[0], w[1]};
            }
        }
    }
    if (absent(r, p.format + "pixel_shift_by_row", info)) {
        info.pixel_shift_by_row = default_pixel_shift_by_row(
            info.beam_azimuth_angles_deg, info.pixels_per_column, info.columns_per_frame);
    } else {
        r.integers(p.format + "pixel_shift_by_row", -65535, 65535, &info.pixel_shift_by_row);
    }
}

// beam_intrinsics: the beam origin offset n (mm) and beam_to_lidar_transform, whose x/z
// translation encodes the same n; they must agree. Runs after the identity, as n's
// default depends on prod_line.
void read_beam_origin(Reader& r, const detail::MetadataPaths& p, SensorInfo& info) {
    const bool have_n =
        r.number(p.beam + "lidar_origin_to_beam_origin_mm", &info.lidar_origin_to_beam_origin_mm);
    if (absent(r, p.beam + "lidar_origin_to_beam_origin_mm", info)) {
        info.lidar_origin_to_beam_origin_mm =
            default_lidar_origin_to_beam_origin_mm(info.prod_line);
    }
    if (absent(r, p.beam + "beam_to_lidar_transform", info)) {
        info.beam_to_lidar_transform = Eigen::Matrix4d::Identity();
        info.beam_to_lidar_transform(0, 3) = info.lidar_origin_to_beam_origin_mm;
    } else if (r.matrix4(p.beam + "beam_to_lidar_transform", &info.beam_to_lidar_transform)) {
        const double n_from_matrix =
            std::hypot(info.beam_to_lidar_transform(0, 3), info.beam_to_lidar_transform(2, 3));
        if (!have_n) {
            // n absent: the matrix says where the beams start. The product line's default
            // could contradict it, and the nested form written back (to_nested_json) would
            // then fail to parse, so n follows the matrix.
            info.lidar_origin_to_beam_origin_mm = n_from_matrix;
        } else if (std::fabs(n_from_matrix - info.lidar_origin_to_beam_origin_mm) > 1e-3) {
            std::ostringstream msg;
            msg << "translation gives a beam origin offset of " << n_from_matrix
                << " mm, contradicting " << p.beam << "lidar_origin_to_beam_origin_mm "
                << info.lidar_origin_to_beam_origin_mm;
            r.problem(p.beam + "beam_to_lidar_transform", msg.str());
        }
    }
}

// lidar_intrinsics / imu_intrinsics: lidar and IMU frames in the sensor frame (mm).
void read_sensor_transforms(Reader& r, const detail::MetadataPaths& p, SensorInfo& info) {
    if (absent(r, p.lidar_to_sensor, info)) {
        info.lidar_to_sensor_transform = default_lidar_to_sensor_transform();
    } else {
        r.matrix4(p.lidar_to_sensor, &info.lidar_to_sensor_transform);
    }
    if (absent(r, p.imu_to_sensor, info)) {
        info.imu_to_sensor_transform = default_imu_to_sensor_transform();
    } else {
        r.matrix4(p.imu_to_sensor, &info.imu_to_sensor_transform);
    }
}

// config_params (top level in the flat form): UDP ports and destination, timestamp mode,
// azimuth window in millidegrees.
void read_network_config(Reader& r, const detail::MetadataPaths& p, SensorInfo& info) {
    if (absent(r, p.config + "udp_port_lidar", info)) {
        info.udp_port_lidar = 7502;
    } else {
        r.integer_as(p.config + "udp_port_lidar", 0, 65535, &info.udp_port_lidar);
    }
    if (absent(r, p.config + "udp_port_imu", info)) {
        info.udp_port_imu = 7503;
    } else {
        r.integer_as(p.config + "udp_port_imu", 0, 65535, &info.udp_port_imu);
    }
    if (!r.string(p.config + "udp_dest", &info.udp_dest)) {
        r.string(p.config + "udp_ip", &info.udp_dest);
    }
    r.string(p.config + "timestamp_mode", &info.timestamp_mode);
    if (!absent(r, p.config + "azimuth_window", info)) {
        std::vector<int> w;
        if (r.integers(p.config + "azimuth_window", 0, 360000, &w)) {
            if (w.size() != 2) {
                r.problem(p.config + "azimuth_window",
                          "expected 2 integers [start, end] in millidegrees, got " +
                              std::to_string(w.size()));
            } else {
                info.azimuth_window_mdeg = {w[0], w[1]};
            }
        }
    }
}

// Every part is read even after problems so that one error lists them all. The order is
// the order of the problems in that error, and later parts use earlier parts' values.
SensorInfo parse_root(const json& root, const std::string& source) {
    std::vector<std::string> problems;
    std::set<std::string> bad;
    if (!root.is_object()) {
        throw MetadataError(source, {"(root): expected a JSON object, got " + type_name(root)});
    }
    Reader r(root, &problems, &bad);

    SensorInfo info;
    info.form = read_form(root, r);
    const detail::MetadataPaths p = paths_for(info.form);
    read_identity(r, p, info);
    read_mode(r, p, info);
    read_beam_angles(r, p, info);
    read_packet_layout(r, p, info);
    read_udp_profiles(r, p, info);
    read_column_layout(r, p, info);
    read_beam_origin(r, p, info);
    read_sensor_transforms(r, p, info);
    read_network_config(r, p, info);

    detail::check_semantics(info, p, bad, &problems);
    if (!problems.empty()) throw MetadataError(source, std::move(problems));
    return info;
}

}  // namespace

MetadataError::MetadataError(const std::string& source, std::vector<std::string> problems)
    : std::runtime_error(join_problems(source, problems)),
      source_(source),
      problems_(std::move(problems)) {}

SensorInfo parse_metadata(const std::string& json_text, const std::string& source_name) {
    json root;
    try {
        root = json::parse(json_text);
    } catch (const json::parse_error& e) {
        std::ostringstream msg;
        msg << "malformed JSON at byte " << e.byte << ": " << e.what();
        throw MetadataError(source_name, {msg.str()});
    } catch (const json::exception& e) {
        // The parser's other errors, e.g. out_of_range for a number beyond a double
        // ("5.3e84133"), found by fuzz/fuzz_ouster_metadata: still malformed metadata.
        throw MetadataError(source_name, {std::string("malformed JSON: ") + e.what()});
    }
    return parse_root(root, source_name);
}

SensorInfo load_metadata(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw MetadataError(path.string(), {"cannot open the file for reading"});
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw MetadataError(path.string(), {"read error"});
    return parse_metadata(text.str(), path.string());
}

std::vector<std::string> validate_sensor_info(const SensorInfo& info) {
    std::vector<std::string> problems;
    detail::check_semantics(info, detail::member_paths(), {}, &problems);
    return problems;
}

}  // namespace lidarfuse::ouster

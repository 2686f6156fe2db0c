// libFuzzer harness: Ouster metadata JSON (either document form) -> SensorInfo.
//
// Contract checked besides memory safety (metadata.hpp): any text either parses or throws
// MetadataError (no other exception escapes); what parses is something the daemon can
// use, i.e. a packet format, a scan layout, an assembler and an xyz LUT of the right size
// can all be built from it without throwing; and the nested form written back parses to
// the same mode, profile and beams.
#include <cstddef>
#include <cstdint>
#include <string>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/packet_format.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/xyz_lut.hpp"
#include "fuzz/fuzz_input.hpp"

using namespace lidarfuse;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    ouster::SensorInfo info;
    try {
        info = ouster::parse_metadata(text, "fuzz.json");
    } catch (const ouster::MetadataError& error) {
        if (error.problems().empty()) fuzz::invariant_failed("MetadataError without a problem");
        return 0;
    }
    if (!ouster::validate_sensor_info(info).empty()) {
        fuzz::invariant_failed("parse_metadata accepted what validate_sensor_info rejects");
    }
    // What the daemon builds from accepted metadata (pipeline.cpp) must not throw. The LUT
    // is skipped for very large frames only to keep executions fast.
    const ouster::PacketFormat format(info);
    ouster::ScanAssembler assembler(info, ouster::ScanAssemblerParams{}, nullptr);
    if (assembler.layout().rows != static_cast<std::size_t>(info.pixels_per_column)) {
        fuzz::invariant_failed("layout rows");
    }
    if (static_cast<long>(info.pixels_per_column) * info.columns_per_frame <= 64 * 2048) {
        const ouster::XyzLut lut = ouster::make_xyz_lut(info);
        if (lut.size() != static_cast<std::size_t>(info.pixels_per_column) *
                              static_cast<std::size_t>(info.columns_per_frame)) {
            fuzz::invariant_failed("LUT size");
        }
    }
    (void)format;

    ouster::SensorInfo again;
    try {
        again = ouster::parse_metadata(ouster::to_nested_json(info), "fuzz-rewritten.json");
    } catch (const ouster::MetadataError& error) {
        std::fprintf(stderr, "%s\n", error.what());
        fuzz::invariant_failed("the nested form written back does not parse");
    }
    if (again.columns_per_frame != info.columns_per_frame ||
        again.pixels_per_column != info.pixels_per_column ||
        again.columns_per_packet != info.columns_per_packet ||
        again.udp_profile_lidar != info.udp_profile_lidar ||
        again.column_window != info.column_window ||
        again.pixel_shift_by_row != info.pixel_shift_by_row ||
        again.beam_altitude_angles_deg.size() != info.beam_altitude_angles_deg.size() ||
        again.serial_number() != info.serial_number()) {
        fuzz::invariant_failed("the nested form written back differs");
    }
    return 0;
}

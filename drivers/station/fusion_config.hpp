#pragma once
// station.yaml's `registration` and `dynamics` sections (config/station.schema.md) as
// core::FusionParams. lidarfused reads them with the rest of its config (daemon_config),
// and `lidarfuse fuse` and `lidarfuse calibrate` read them too, so that a capture is
// processed offline with the parameters the station runs with. A missing key keeps the
// FusionParams default; the other sections of the file are not looked at here.

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "core/pipeline/fusion_types.hpp"
#include "drivers/station/yaml_reader.hpp"

namespace lidarfuse::station {

// Reads both sections of `document` (a mapping) into `params`; every problem goes to
// r.problems with its key path.
void read_fusion_sections(YamlReader& r, const YAML::Node& document, core::FusionParams* params);

// The sections of a whole file on top of the defaults; throws ConfigError naming the file
// and listing every problem.
core::FusionParams load_fusion_params(const std::filesystem::path& file);

}  // namespace lidarfuse::station

#include "drivers/station/fusion_config.hpp"

#include "drivers/station/station_config.hpp"

namespace lidarfuse::station {

namespace {

// registration.initial_method: features (one station's sensors) or stations (a segment
// daemon's sensors are stations' fused clouds in their road frames).
void read_initial_method(YamlReader& r, const YAML::Node& n, core::InitialRegistrationParams* p) {
    if (const auto k = r.choice(n, "registration.initial_method", {"features", "stations"})) {
        p->method = *k == 0 ? core::InitialRegistrationMethod::kFeatures
                            : core::InitialRegistrationMethod::kStations;
    }
}

// registration.correspondence_factor's default for the sensors the initial method places:
// FusionParams' for one station's sensors, 0.5 for the stations of a segment. Between
// viewpoints 60-100 m apart a wider bound pairs one station's centroids with the other's
// samples of nearby surfaces (the road seen at a grazing angle), and the edges between the
// two come out tilted, all the same way, so that no window of them averages it out
// (bench/BENCHMARK.md, "The correspondence bound").
double default_correspondence_factor(core::InitialRegistrationMethod method) {
    return method == core::InitialRegistrationMethod::kStations
               ? 0.5
               : core::FusionParams{}.correspondence_factor;
}

// The parameters PAPER.md names are all here: voxel sizes, k_w, r_c, RANSAC iterations,
// Huber delta (and the attenuation, under dynamics).
void read_registration(YamlReader& r, const YAML::Node& n, core::FusionParams* f) {
    if (!n || !r.optional_map(n, "registration")) return;
    const std::string p = "registration.";
    r.only_keys(n, "registration",
                {"voxel_size_m", "window_frames", "covariance_neighbors", "correspondence_factor",
                 "huber_delta", "deskew", "min_fitness", "max_jump_m", "max_jump_deg",
                 "divergence_frames", "retry_interval_frames", "threads",
                 "initial_max_voxel_size_m", "initial_min_voxel_size_m", "ransac_iterations",
                 "ransac_inlier_threshold_m", "p2p_cutoff_m", "seed", "initial_method"});
    read_initial_method(r, n["initial_method"], &f->initial);
    set_if(r.number(n["voxel_size_m"], p + "voxel_size_m", 0.05, 20, false), &f->voxel_size_m);
    set_if(r.integer(n["window_frames"], p + "window_frames", 2, 100, false), &f->window_frames);
    if (const auto k =
            r.integer(n["covariance_neighbors"], p + "covariance_neighbors", 0, 100, false)) {
        if (*k >= 1 && *k <= 3) {
            r.problems.push_back(
                p + "covariance_neighbors: expected 0 (by voxel size) or 4..100, got " +
                std::to_string(*k));
        } else {
            f->covariance_neighbors = static_cast<int>(*k);
        }
    }
    f->correspondence_factor = default_correspondence_factor(f->initial.method);
    set_if(r.number(n["correspondence_factor"], p + "correspondence_factor", 0.5, 10, false),
           &f->correspondence_factor);
    set_if(r.number(n["huber_delta"], p + "huber_delta", 0, 100, false), &f->huber_delta);
    set_if(r.boolean(n["deskew"], p + "deskew"), &f->deskew);
    set_if(r.number(n["min_fitness"], p + "min_fitness", 0, 1, false), &f->min_fitness);
    set_if(r.number(n["max_jump_m"], p + "max_jump_m", 0.01, 100, false), &f->max_jump_m);
    set_if(r.number(n["max_jump_deg"], p + "max_jump_deg", 0.1, 180, false), &f->max_jump_deg);
    set_if(r.integer(n["divergence_frames"], p + "divergence_frames", 1, 1000, false),
           &f->divergence_frames);
    set_if(r.integer(n["retry_interval_frames"], p + "retry_interval_frames", 1, 100000, false),
           &f->retry_interval_frames);
    set_if(r.integer(n["threads"], p + "threads", 1, 64, false), &f->num_threads);
    auto& init = f->initial;
    set_if(r.number(n["initial_max_voxel_size_m"], p + "initial_max_voxel_size_m", 0.05, 20, false),
           &init.features.octree.max_voxel_size_m);
    set_if(r.number(n["initial_min_voxel_size_m"], p + "initial_min_voxel_size_m", 0.01, 20, false),
           &init.features.octree.min_voxel_size_m);
    set_if(r.integer(n["ransac_iterations"], p + "ransac_iterations", 10, 10000000, false),
           &init.pair.ransac.max_iterations);
    set_if(
        r.number(n["ransac_inlier_threshold_m"], p + "ransac_inlier_threshold_m", 0.01, 20, false),
        &init.pair.ransac.inlier_threshold_m);
    set_if(r.number(n["p2p_cutoff_m"], p + "p2p_cutoff_m", 0.01, 50, false),
           &init.pair.p2p_cutoff_m);
    set_if(r.integer(n["seed"], p + "seed", 0, 0xFFFFFFFFLL, false), &init.pair.ransac.seed);
    if (init.features.octree.min_voxel_size_m > init.features.octree.max_voxel_size_m) {
        r.problems.push_back(p +
                             "initial_min_voxel_size_m: must not exceed initial_max_voxel_size_m");
    }
}

void read_dynamics(YamlReader& r, const YAML::Node& n, core::FusionParams* f) {
    if (!n || !r.optional_map(n, "dynamics")) return;
    const std::string p = "dynamics.";
    r.only_keys(n, "dynamics",
                {"enabled", "attenuation", "range_threshold_m", "dynamic_threshold", "voxel_size_m",
                 "cone_bins"});
    auto& b = f->background;
    set_if(r.boolean(n["enabled"], p + "enabled"), &f->remove_dynamic);
    set_if(r.number(n["attenuation"], p + "attenuation", 0, 1, false), &b.attenuation);
    set_if(r.number(n["range_threshold_m"], p + "range_threshold_m", 0.01, 20, false),
           &b.change.range_threshold_m);
    set_if(r.number(n["dynamic_threshold"], p + "dynamic_threshold", 0, 100, false),
           &b.dynamic_threshold);
    set_if(r.number(n["voxel_size_m"], p + "voxel_size_m", 0.05, 10, false), &b.voxel_size_m);
    set_if(r.integer(n["cone_bins"], p + "cone_bins", 0, 10, false), &b.change.cone_bins);
}

}  // namespace

void read_fusion_sections(YamlReader& r, const YAML::Node& document, core::FusionParams* params) {
    read_registration(r, document["registration"], params);
    read_dynamics(r, document["dynamics"], params);
}

core::FusionParams load_fusion_params(const std::filesystem::path& file) {
    const YAML::Node document = load_config_document(read_config_file(file), file.string());
    core::FusionParams params;
    YamlReader r;
    read_fusion_sections(r, document, &params);
    if (!r.problems.empty()) throw ConfigError(file.string(), r.problems);
    return params;
}

}  // namespace lidarfuse::station

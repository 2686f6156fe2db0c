// `lidarfuse eval --gt ground_truth.csv --poses poses.csv [--root NAME] [--plot DIR]`
// Prints the paper's accuracy figures (and the strict ones) as `name value unit` lines.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "core/evaluation/evaluation.hpp"
#include "drivers/io/fused_cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"
#include "tools/args.hpp"
#include "tools/command.hpp"
#include "tools/svg_plot.hpp"

namespace lidarfuse::tools {

namespace {

void write_plot(const std::filesystem::path& file, const core::EvaluationResult& result,
                const std::string& title, const std::string& unit,
                std::vector<double> core::SensorErrors::*errors) {
    PlotSpec spec{title, "time since first sample [s]", unit, {}};
    std::int64_t t0 = 0;
    bool have_t0 = false;
    for (const auto& s : result.sensors) {
        if (!s.t_ns.empty() && (!have_t0 || s.t_ns.front() < t0))
            t0 = s.t_ns.front(), have_t0 = true;
    }
    for (const auto& s : result.sensors) {
        PlotSeries series{s.sensor, {}, s.*errors};
        for (auto t : s.t_ns) series.x.push_back(static_cast<double>(t - t0) * 1e-9);
        spec.series.push_back(std::move(series));
    }
    std::ofstream(file) << render_svg_line_plot(spec);
}

const char* const kUsage =
    "usage: lidarfuse eval --gt ground_truth.csv --poses poses.csv [--root NAME]\n"
    "                      [--tolerance-ms 25] [--plot DIR [--cloud FUSED.ply]]\n"
    "Per sensor and on average: translation and rotation RMSE over frames, after\n"
    "fitting T_coord by SVD from the sensor positions (the paper's metric), and without\n"
    "any fitted alignment (strict: both relative to the root sensor at its first frame, "
    "so\n"
    "poses.csv may be in any world frame). --plot writes error-over-time SVGs into DIR, "
    "and\n"
    "with --cloud (a fused frame from fuse --save-cloud) DIR/top_view.svg coloured by "
    "sensor.\n"
    "--world road: also each sensor's height and up-direction error in poses.csv's own\n"
    "frame against the truth's (which must be road-aligned, as the simulator's is);\n"
    "--world geo [--world-offset X,Y,Z]: poses.csv (plus the offset: extrinsics.yaml's\n"
    "world.T_world_fused translation) against the truth directly, no alignment.\n";

core::EvaluationParams eval_params(const Args& args) {
    core::EvaluationParams params;
    params.root_sensor = args.value("--root").value_or("");
    params.match_tolerance_ns =
        static_cast<std::int64_t>(args.number("--tolerance-ms", 25.0) * 1e6);
    if (const auto w = args.value("--world")) {
        if (*w == "road") {
            params.world = core::EvaluationParams::World::kRoad;
        } else if (*w == "geo") {
            params.world = core::EvaluationParams::World::kGeo;
        } else if (*w != "sensor") {
            throw UsageError("--world: expected road, geo or sensor, got \"" + *w + "\"");
        }
    }
    if (const auto o = args.value("--world-offset")) {
        double x = 0, y = 0, z = 0;
        char tail = 0;
        if (std::sscanf(o->c_str(), "%lf,%lf,%lf%c", &x, &y, &z, &tail) != 3) {
            throw UsageError("--world-offset: expected X,Y,Z in metres, got \"" + *o + "\"");
        }
        params.world_offset = Eigen::Vector3d(x, y, z);
    }
    return params;
}

void print_sensor_errors(const core::SensorErrors& s, core::EvaluationParams::World world) {
    const char* n = s.sensor.c_str();
    std::printf("eval_%s_matched_frames %zu frames\n", n, s.matched);
    std::printf("eval_%s_missing_frames %zu frames\n", n, s.missing);
    std::printf("eval_%s_rmse_trans %.6f m\n", n, s.rmse_trans_m);
    std::printf("eval_%s_rmse_rot %.6f deg\n", n, s.rmse_rot_deg);
    std::printf("eval_%s_strict_rmse_trans %.6f m\n", n, s.strict_rmse_trans_m);
    std::printf("eval_%s_strict_rmse_rot %.6f deg\n", n, s.strict_rmse_rot_deg);
    std::printf("eval_%s_max_trans %.6f m\n", n, s.max_trans_m);
    std::printf("eval_%s_first_tenth_strict_rmse_trans %.6f m\n", n, s.first_tenth_rmse_trans_m);
    std::printf("eval_%s_last_tenth_strict_rmse_trans %.6f m\n", n, s.last_tenth_rmse_trans_m);
    if (world == core::EvaluationParams::World::kRoad) {
        std::printf("eval_%s_world_height_rmse %.6f m\n", n, s.world_rmse_trans_m);
        std::printf("eval_%s_world_height_max %.6f m\n", n, s.world_max_trans_m);
        std::printf("eval_%s_world_up_rmse %.6f deg\n", n, s.world_rmse_rot_deg);
    } else if (world == core::EvaluationParams::World::kGeo) {
        std::printf("eval_%s_world_rmse_trans %.6f m\n", n, s.world_rmse_trans_m);
        std::printf("eval_%s_world_max_trans %.6f m\n", n, s.world_max_trans_m);
        std::printf("eval_%s_world_rmse_rot %.6f deg\n", n, s.world_rmse_rot_deg);
    }
}

void print_result(const core::EvaluationResult& result, core::EvaluationParams::World world) {
    std::printf("eval_root_sensor %s name\n", result.root_sensor.c_str());
    std::printf("eval_alignment %s method\n", result.alignment.c_str());
    for (const auto& s : result.sensors) print_sensor_errors(s, world);
    std::printf("eval_mean_rmse_trans %.6f m\n", result.mean_rmse_trans_m);
    std::printf("eval_mean_rmse_rot %.6f deg\n", result.mean_rmse_rot_deg);
    std::printf("eval_mean_strict_rmse_trans %.6f m\n", result.mean_strict_rmse_trans_m);
    std::printf("eval_mean_strict_rmse_rot %.6f deg\n", result.mean_strict_rmse_rot_deg);
    if (world == core::EvaluationParams::World::kRoad) {
        std::printf("eval_mean_world_height_rmse %.6f m\n", result.mean_world_rmse_trans_m);
        std::printf("eval_mean_world_up_rmse %.6f deg\n", result.mean_world_rmse_rot_deg);
    } else if (world == core::EvaluationParams::World::kGeo) {
        std::printf("eval_mean_world_rmse_trans %.6f m\n", result.mean_world_rmse_trans_m);
        std::printf("eval_mean_world_rmse_rot %.6f deg\n", result.mean_world_rmse_rot_deg);
    }
}

// DIR/top_view.svg: a fused frame (fuse --save-cloud) from above, coloured by sensor.
void write_top_view(const std::filesystem::path& dir, const std::string& cloud_file) {
    const auto cloud = io::read_fused_cloud_ply(cloud_file);
    TopViewSpec view;
    view.title =
        "Fused frame, top view (" + std::filesystem::path(cloud_file).filename().string() + ")";
    std::uint8_t max_sensor = 0;
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
        view.x.push_back(cloud.points[i].x());
        view.y.push_back(cloud.points[i].y());
        max_sensor = std::max(max_sensor, cloud.sensor[i]);
    }
    view.sensor = cloud.sensor;
    view.dynamic = cloud.dynamic;
    for (int s = 0; s <= max_sensor; ++s)
        view.sensor_labels.push_back("sensor " + std::to_string(s));
    std::ofstream(dir / "top_view.svg") << render_svg_top_view(view);
    std::printf("eval_top_view_points %zu points\n", cloud.points.size());
}

void write_plots(const std::string& dir, const std::optional<std::string>& cloud_file,
                 const core::EvaluationResult& result) {
    std::filesystem::create_directories(dir);
    const std::filesystem::path d(dir);
    write_plot(d / "translation_error.svg", result, "Translation error (aligned)", "m",
               &core::SensorErrors::trans_err_m);
    write_plot(d / "rotation_error.svg", result, "Rotation error (aligned)", "deg",
               &core::SensorErrors::rot_err_deg);
    write_plot(d / "strict_translation_error.svg", result, "Translation error (strict)", "m",
               &core::SensorErrors::strict_trans_err_m);
    write_plot(d / "strict_rotation_error.svg", result, "Rotation error (strict)", "deg",
               &core::SensorErrors::strict_rot_err_deg);
    if (cloud_file) write_top_view(d, *cloud_file);
    std::fprintf(stderr, "plots written to %s\n", dir.c_str());
}

int run_eval(int argc, char** argv) {
    const Args args(argc, argv,
                    {"--gt", "--poses", "--root", "--plot", "--tolerance-ms", "--cloud", "--world",
                     "--world-offset"},
                    {});
    if (args.help()) {
        std::printf("%s", kUsage);
        return 0;
    }
    if (args.value("--cloud") && !args.value("--plot"))
        throw UsageError("--cloud needs --plot DIR");
    const auto truth = io::to_trajectories(io::read_pose_csv(args.required("--gt")));
    const auto estimate = io::to_trajectories(io::read_pose_csv(args.required("--poses")));
    const core::EvaluationParams params = eval_params(args);
    const auto result = core::evaluate_trajectories(truth, estimate, params);
    if (!result.ok) {
        std::fprintf(stderr, "lidarfuse eval: %s\n", result.error.c_str());
        return 1;
    }
    print_result(result, params.world);
    if (const auto dir = args.value("--plot")) write_plots(*dir, args.value("--cloud"), result);
    return 0;
}

}  // namespace

LIDARFUSE_REGISTER_COMMAND("eval", "accuracy of poses.csv against ground_truth.csv", run_eval);

}  // namespace lidarfuse::tools

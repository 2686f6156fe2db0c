// lidarfuse::core from outside the project: the extrinsics between two LiDARs from one cloud
// of each, with no target and no initial guess (the paper's initial registration, one call).
//
//   register_two_clouds TARGET SOURCE
//
// TARGET and SOURCE are ASCII PCD files (DATA ascii, x y z the first fields) or text files of
// "x y z" lines, each in its own sensor's frame, in metres. Prints T_target_source (the
// source sensor's pose in the target's frame) as a 4 x 4 matrix; exit status 0 when it was
// registered, 2 when the data did not decide it (refused, never guessed), 1 on bad input.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <lidarfuse/core/initial/initial_registration.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// The points of one file; PCD headers are read up to DATA, which must say ascii.
lidarfuse::core::PointCloud read_points(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open");
    lidarfuse::core::PointCloud cloud;
    std::string line;
    bool pcd_header = false;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        if (line.rfind("VERSION", 0) == 0 || line.rfind("FIELDS", 0) == 0) pcd_header = true;
        if (pcd_header) {
            if (line.rfind("FIELDS", 0) == 0 && line.rfind("FIELDS x y z", 0) != 0)
                throw std::runtime_error(path + ": FIELDS must start with x y z, not: " + line);
            if (line.rfind("DATA", 0) == 0) {
                if (line != "DATA ascii")
                    throw std::runtime_error(path + ": expected DATA ascii, not: " + line);
                pcd_header = false;
            }
            continue;
        }
        std::istringstream fields(line);
        Eigen::Vector3d p;
        if (!(fields >> p.x() >> p.y() >> p.z()))
            throw std::runtime_error(path + ": expected x y z, not: " + line);
        if (p.allFinite()) cloud.points.push_back(p);  // no-return pixels: NaN or the origin
    }
    if (cloud.empty()) throw std::runtime_error(path + ": no points");
    return cloud;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::cerr << "usage: register_two_clouds TARGET SOURCE\n";
        return 1;
    }
    std::vector<lidarfuse::core::PointCloud> clouds;
    try {
        clouds = {read_points(argv[1]), read_points(argv[2])};  // the target is the root
    } catch (const std::exception& e) {
        std::cerr << "register_two_clouds: " << e.what() << "\n";
        return 1;
    }
    const auto result = lidarfuse::core::register_initial(clouds);
    const auto& source = result.sensors[1];
    if (!source.registered) {
        std::cerr << "register_two_clouds: not registered: " << to_string(source.status) << "\n";
        return 2;
    }
    const Eigen::Matrix4d T = source.T_root_sensor.matrix();
    for (int r = 0; r < 4; ++r) {
        std::printf("%.9f %.9f %.9f %.9f\n", T(r, 0), T(r, 1), T(r, 2), T(r, 3));
    }
    return 0;
}

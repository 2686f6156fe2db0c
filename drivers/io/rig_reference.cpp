#include "drivers/io/rig_reference.hpp"

#include <fstream>
#include <stdexcept>

namespace lidarfuse::io {

Eigen::Isometry3d read_rig_reference(const std::filesystem::path& file) {
    std::ifstream in(file);
    if (!in) throw std::runtime_error(file.string() + ": cannot open");
    Eigen::Matrix4d M;
    for (int k = 0; k < 16; ++k) {
        if (!(in >> M(k / 4, k % 4))) {
            throw std::runtime_error(file.string() + ": expected 16 numbers (4 x 4, row-major)");
        }
    }
    if (!M.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1))) {
        throw std::runtime_error(file.string() + ": the last row must be 0 0 0 1");
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.matrix() = M;
    return T;
}

}  // namespace lidarfuse::io

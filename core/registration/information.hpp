#pragma once
// Whether a G-ICP Hessian can serve as a pose-graph edge's information matrix: finite and
// positive definite (its Cholesky factor exists), in the se(3) tangent of se3.hpp.
#include <Eigen/Cholesky>

#include "core/common/se3.hpp"

namespace lidarfuse::core {

inline bool usable_information(const Matrix6d& H) {
    return H.allFinite() && Eigen::LLT<Matrix6d>(H).info() == Eigen::Success;
}

}  // namespace lidarfuse::core

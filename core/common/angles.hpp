#pragma once
// Angle constants shared by the core: one definition, so that every unit (and a unity build
// that compiles several units as one) agrees on them.

namespace lidarfuse::core {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegToRad = kPi / 180.0;  // rad per degree

}  // namespace lidarfuse::core

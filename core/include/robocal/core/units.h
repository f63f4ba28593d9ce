// Angle units: the core computes in radians, the wire and the people read degrees. The one pair of conversion
// constants of the project (core, wire, import, report and tests alike).
#pragma once

#include <cmath>
#include <numbers>

namespace robocal {

/// Degrees per radian: degrees = radians * kDegPerRad.
inline constexpr double kDegPerRad = 180.0 / std::numbers::pi;
/// Radians per degree: radians = degrees * kRadPerDeg.
inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;

/// `angle` (rad) wrapped into [-pi, pi].
inline double WrapAngle(double angle) { return std::remainder(angle, 2.0 * std::numbers::pi); }

}  // namespace robocal

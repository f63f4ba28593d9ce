// A dialect's Cartesian values <-> a pose: positions in the dialect's length unit, rotations in its convention
// (KUKA Z Y' X'', FANUC fixed X Y Z, ABB's quaternion w first, UR's rotation vector, Staubli X Y' Z''). Going
// back, of the equivalent ways to write a rotation the one nearest the numbers as written is chosen, so that a
// target the compensation hardly moves is written with numbers that hardly change.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "robocal/core/units.h"
#include "robocal/programs/compensate_program.h"

namespace robocal::programs {
namespace {

constexpr double kPi = std::numbers::pi;

// `angle` plus the whole turns that bring it nearest `near` (rad).
double NearestTurn(double angle, double near) { return angle + 2.0 * kPi * std::round((near - angle) / (2.0 * kPi)); }

// The two Euler sets of R = R1(a) R2(b) R3(c) for the intrinsic sequences used here, as (a, b, c) in rad, with
// the one nearest `near` (rad) returned, each angle at its turn nearest it. `zyx`: R = Rz(a) Ry(b) Rx(c);
// otherwise R = Rx(a) Ry(b) Rz(c).
Eigen::Vector3d NearestEuler(const Eigen::Matrix3d& R, bool zyx, const Eigen::Vector3d& near) {
  double a, b, c;
  // sin(b) and the two products that give a and c, by the sequence.
  const double s = zyx ? -R(2, 0) : R(0, 2);
  b = std::asin(std::clamp(s, -1.0, 1.0));
  const double cb = std::cos(b);
  Eigen::Vector3d first, second;
  if (cb > 1e-9) {
    if (zyx) {
      a = std::atan2(R(1, 0), R(0, 0));
      c = std::atan2(R(2, 1), R(2, 2));
    } else {
      a = std::atan2(-R(1, 2), R(2, 2));
      c = std::atan2(-R(0, 1), R(0, 0));
    }
    first = {a, b, c};
    second = {a + kPi, kPi - b, c + kPi};
  } else {
    // Gimbal lock: only a + c (or a - c) is determined; a keeps its written value.
    a = near[0];
    // With a fixed, the rest is R1(-a) R = R2(b) R3(c), whose second row gives c.
    if (zyx) {
      const Eigen::Matrix3d M = Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R;
      c = std::atan2(-M(1, 2), M(1, 1));
    } else {
      const Eigen::Matrix3d M = Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitX()).toRotationMatrix() * R;
      c = std::atan2(M(1, 0), M(1, 1));
    }
    first = {a, b, c};
    second = first;
  }
  auto place = [&](Eigen::Vector3d v) {
    for (int k = 0; k < 3; ++k) v[k] = NearestTurn(v[k], near[k]);
    return v;
  };
  first = place(first);
  second = place(second);
  return (first - near).squaredNorm() <= (second - near).squaredNorm() ? first : second;
}

Eigen::Matrix3d EulerRotation(const Eigen::Vector3d& angles, bool zyx) {
  using Eigen::AngleAxisd;
  using Eigen::Vector3d;
  if (zyx) {
    return (AngleAxisd(angles[0], Vector3d::UnitZ()) * AngleAxisd(angles[1], Vector3d::UnitY()) *
            AngleAxisd(angles[2], Vector3d::UnitX()))
        .toRotationMatrix();
  }
  return (AngleAxisd(angles[0], Vector3d::UnitX()) * AngleAxisd(angles[1], Vector3d::UnitY()) *
          AngleAxisd(angles[2], Vector3d::UnitZ()))
      .toRotationMatrix();
}

std::size_t ValueCount(RotationConvention convention) {
  return convention == RotationConvention::kQuaternionWxyz ? 7 : 6;
}

}  // namespace

Transform PoseFromValues(const DialectSyntax& syntax, const std::vector<double>& v) {
  const std::size_t count = ValueCount(syntax.rotation);
  if (v.size() != count) {
    throw std::invalid_argument("expected " + std::to_string(count) + " values (x, y, z and the rotation), got " +
                                std::to_string(v.size()));
  }
  for (double x : v) {
    if (!std::isfinite(x)) throw std::invalid_argument("a value is not finite");
  }
  Transform pose = Transform::Identity();
  pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]) * syntax.mm_per_length_unit;
  switch (syntax.rotation) {
    case RotationConvention::kZyxIntrinsicDeg:
      pose.linear() = EulerRotation(Eigen::Vector3d(v[3], v[4], v[5]) * kRadPerDeg, true);
      break;
    case RotationConvention::kXyzFixedDeg:
      // Fixed X, Y, Z by W, P, R is Rz(R) Ry(P) Rx(W).
      pose.linear() = EulerRotation(Eigen::Vector3d(v[5], v[4], v[3]) * kRadPerDeg, true);
      break;
    case RotationConvention::kXyzIntrinsicDeg:
      pose.linear() = EulerRotation(Eigen::Vector3d(v[3], v[4], v[5]) * kRadPerDeg, false);
      break;
    case RotationConvention::kQuaternionWxyz: {
      Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
      const double norm = q.norm();
      // Controllers normalise what they are given; a quaternion far from unit length is a mistake in the program.
      if (std::abs(norm - 1.0) > 1e-3) {
        throw std::invalid_argument("the quaternion's norm is " + std::to_string(norm) + ", not 1");
      }
      pose.linear() = q.normalized().toRotationMatrix();
      break;
    }
    case RotationConvention::kRotationVectorRad: {
      const Eigen::Vector3d r(v[3], v[4], v[5]);
      const double angle = r.norm();
      if (angle > 0.0) pose.linear() = Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
      break;
    }
  }
  return pose;
}

std::vector<double> ValuesFromPose(const DialectSyntax& syntax, const Transform& pose,
                                   const std::vector<double>& near) {
  const std::size_t count = ValueCount(syntax.rotation);
  if (near.size() != count) throw std::invalid_argument("ValuesFromPose: `near` has the wrong size");
  std::vector<double> v(count);
  const Eigen::Vector3d p = pose.translation() / syntax.mm_per_length_unit;
  v[0] = p.x();
  v[1] = p.y();
  v[2] = p.z();
  const Eigen::Matrix3d R = pose.linear();
  switch (syntax.rotation) {
    case RotationConvention::kZyxIntrinsicDeg:
    case RotationConvention::kXyzIntrinsicDeg: {
      const bool zyx = syntax.rotation == RotationConvention::kZyxIntrinsicDeg;
      const Eigen::Vector3d e =
          NearestEuler(R, zyx, Eigen::Vector3d(near[3], near[4], near[5]) * kRadPerDeg) * kDegPerRad;
      v[3] = e[0], v[4] = e[1], v[5] = e[2];
      break;
    }
    case RotationConvention::kXyzFixedDeg: {
      const Eigen::Vector3d e =
          NearestEuler(R, true, Eigen::Vector3d(near[5], near[4], near[3]) * kRadPerDeg) * kDegPerRad;
      v[3] = e[2], v[4] = e[1], v[5] = e[0];
      break;
    }
    case RotationConvention::kQuaternionWxyz: {
      Eigen::Quaterniond q(R);
      q.normalize();
      const Eigen::Vector4d written(near[3], near[4], near[5], near[6]);
      Eigen::Vector4d wxyz(q.w(), q.x(), q.y(), q.z());
      if (wxyz.dot(written) < 0.0) wxyz = -wxyz;  // q and -q are one rotation: the sign as written
      // And the length as written: controllers normalise what they read, and a quaternion written with 6 decimals
      // is unit only to about 1e-6, so a unit one would rewrite the components of a target that did not move.
      const double length = written.norm();
      if (length > 0.5) wxyz *= length;
      for (int k = 0; k < 4; ++k) v[3 + k] = wxyz[k];
      break;
    }
    case RotationConvention::kRotationVectorRad: {
      Eigen::Vector3d r = RotationVector(R);
      const Eigen::Vector3d written(near[3], near[4], near[5]);
      const double angle = r.norm();
      if (angle > 1e-12) {
        // axis * (angle + 2 pi k) and -axis * (2 pi - angle) ... are the same rotation: the one nearest as written.
        const Eigen::Vector3d axis = r / angle;
        Eigen::Vector3d best = r;
        for (int k = -2; k <= 2; ++k) {
          for (double sign : {1.0, -1.0}) {
            const Eigen::Vector3d candidate = sign * axis * (sign * angle + 2.0 * kPi * k);
            if ((candidate - written).squaredNorm() < (best - written).squaredNorm()) best = candidate;
          }
        }
        r = best;
      }
      v[3] = r.x(), v[4] = r.y(), v[5] = r.z();
      break;
    }
  }
  return v;
}

}  // namespace robocal::programs

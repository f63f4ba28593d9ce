// Closed-form inverse kinematics of the spherical-wrist and offset-wrist 6R families, written in the product of
// exponentials form with the subproblems of Paden and Kahan (Murray, Li & Sastry, "A Mathematical Introduction
// to Robotic Manipulation", 1994, section 3.2): each joint angle is the solution of "turn a vector about an axis
// onto another" or "turn it until its dot product with a vector is a given value". Written here because it is
// a few dozen lines on the robot model's own axes, and works for any description of the same geometry.
#include "robocal/core/arm_kinematics.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "robocal/core/kinematics.h"
#include "robocal/core/units.h"

namespace robocal {
namespace {

constexpr double kParallelSine = 1e-9;      // |w_i x w_j| below this: parallel axes
constexpr double kMeet = 1e-6;          // mm: lines closer than this meet
// A pose this little beyond reach (cos > 1 by at most this) still gives the stretched solution: a seed for the
// calibrated model, which may reach a little further than the nominal one.
constexpr double kBeyondReach = 5e-2;
// Candidates missing their pose by more than this are dropped (a free joint's fallback, far beyond reach).
constexpr double kSeedMm = 20.0;
constexpr double kSeedRad = 0.1;
// Below this sine of the angle between axis 6 and the parallel axes, the offset wrist's joint 6 is taken as
// ill-determined (about 3 deg from the wrist singularity).
constexpr double kNearlyParallel = 0.05;

Eigen::Matrix3d Rot(const Eigen::Vector3d& w, double angle) { return Eigen::AngleAxisd(angle, w).toRotationMatrix(); }


// Subproblem 1: the angle turning u about w onto v (their parts perpendicular to w); nullopt when either part
// vanishes (any angle will do).
std::optional<double> RotateTo(const Eigen::Vector3d& w, const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
  const Eigen::Vector3d up = u - w * w.dot(u), vp = v - w * w.dot(v);
  const double scale = std::max({1.0, u.norm(), v.norm()});
  if (up.norm() < 1e-12 * scale || vp.norm() < 1e-12 * scale) return std::nullopt;
  return std::atan2(w.dot(up.cross(vp)), up.dot(vp));
}

// The angles turning u about w so that a . R u = c (two, one twice at a tangency, none when out of reach);
// `free` is set when every angle will do (u along w, or a along w with the equation met).
std::vector<double> RotateToDot(const Eigen::Vector3d& w, const Eigen::Vector3d& u, const Eigen::Vector3d& a,
                                double c, bool* free) {
  *free = false;
  const Eigen::Vector3d u_par = w * w.dot(u), u_perp = u - u_par;
  const double A = a.dot(u_perp), B = a.dot(w.cross(u_perp)), C = c - a.dot(u_par);
  const double rho = std::hypot(A, B);
  const double scale = std::max(1.0, a.norm() * u.norm());
  if (rho < 1e-12 * scale) {
    *free = std::abs(C) < 1e-9 * scale;
    return {};
  }
  const double ratio = C / rho;
  if (std::abs(ratio) > 1.0 + kBeyondReach) return {};
  const double phi = std::atan2(B, A);
  if (std::abs(ratio) > 1.0) {
    // Just beyond reach: two starts either side of the stretched angle, as far from it as the reach is
    // exceeded (the mirror of acos(1 - e) ~ sqrt(2 e)), so that each lies on its own branch.
    const double base = ratio > 0.0 ? phi : phi + std::numbers::pi;
    const double alpha = std::max(std::sqrt(2.0 * (std::abs(ratio) - 1.0)), 1e-3);
    return {WrapAngle(base + alpha), WrapAngle(base - alpha)};
  }
  const double alpha = std::acos(ratio);
  return {WrapAngle(phi + alpha), WrapAngle(phi - alpha)};
}

// The same, with the value of a free angle taken from `fallback`.
std::vector<double> RotateToDotOr(const Eigen::Vector3d& w, const Eigen::Vector3d& u, const Eigen::Vector3d& a,
                                  double c, double fallback) {
  bool free = false;
  std::vector<double> angles = RotateToDot(w, u, a, c, &free);
  if (free) angles.push_back(fallback);
  return angles;
}

bool Parallel(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.cross(b).norm() < kParallelSine; }

// The point of line (pa, wa) closest to line (pb, wb) (non-parallel lines), and their distance.
Eigen::Vector3d ClosestPoint(const Eigen::Vector3d& pa, const Eigen::Vector3d& wa, const Eigen::Vector3d& pb,
                             const Eigen::Vector3d& wb, double* distance) {
  const Eigen::Vector3d n = wa.cross(wb);
  *distance = std::abs((pb - pa).dot(n)) / n.norm();
  const double t = (pb - pa).cross(wb).dot(n) / n.squaredNorm();
  return pa + t * wa;
}

Eigen::Vector3d AnyPerpendicular(const Eigen::Vector3d& w) {
  const Eigen::Vector3d x = std::abs(w.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return (x - w * w.dot(x)).normalized();
}

}  // namespace

const char* ToString(ArmFamily family) {
  return family == ArmFamily::kSphericalWrist ? "spherical_wrist" : "offset_wrist";
}

bool ArmConfiguration::Admits(const ArmConfiguration& other) const {
  return (shoulder == 0 || shoulder == other.shoulder) && (elbow == 0 || elbow == other.elbow) &&
         (wrist == 0 || wrist == other.wrist);
}

std::string ArmConfiguration::ToString() const {
  std::string text;
  auto add = [&](const char* flag, const char* name) { text += (text.empty() ? "" : ", ") + std::string(flag) + " " + name; };
  if (shoulder != 0) add("shoulder", ShoulderName(shoulder));
  if (elbow != 0) add("elbow", ElbowName(elbow));
  if (wrist != 0) add("wrist", WristName(wrist));
  return text;
}

const char* ShoulderName(int flag) { return flag >= 0 ? "front" : "back"; }
const char* ElbowName(int flag) { return flag >= 0 ? "up" : "down"; }
const char* WristName(int flag) { return flag >= 0 ? "noflip" : "flip"; }

bool ParseConfigurationFlag(const std::string& flag, const std::string& name, int* value) {
  const char* (*names)(int) = flag == "shoulder" ? ShoulderName : flag == "elbow" ? ElbowName
                              : flag == "wrist"  ? WristName
                                                 : nullptr;
  if (names == nullptr) return false;
  for (int v : {1, -1}) {
    if (name == names(v)) {
      *value = v;
      return true;
    }
  }
  return false;
}

std::optional<ArmSolver> ArmSolver::For(const RobotModel& model) {
  if (model.num_joints() != 6) return std::nullopt;
  for (int i = 0; i < 6; ++i) {
    if (model.joint_type(i) != JointType::kRevolute) return std::nullopt;
  }
  Transform frames[6], flange;
  NominalChainInBase(model, Eigen::VectorXd::Zero(6), frames, &flange);
  Eigen::Vector3d w[6], p[6];
  for (int i = 0; i < 6; ++i) {
    w[i] = frames[i].linear().col(2);
    p[i] = frames[i].translation();
  }
  if (!Parallel(w[1], w[2]) || Parallel(w[0], w[1])) return std::nullopt;
  double d45 = 0.0, d56 = 0.0;
  if (!Parallel(w[3], w[4]) && !Parallel(w[4], w[5])) {
    const Eigen::Vector3d x45 = ClosestPoint(p[3], w[3], p[4], w[4], &d45);
    const Eigen::Vector3d x56 = ClosestPoint(p[4], w[4], p[5], w[5], &d56);
    if (d45 < kMeet && d56 < kMeet && (x45 - x56).norm() < kMeet) return ArmSolver(model, ArmFamily::kSphericalWrist);
  }
  if (Parallel(w[2], w[3]) && !Parallel(w[3], w[4]) && !Parallel(w[4], w[5])) {
    ClosestPoint(p[4], w[4], p[5], w[5], &d56);
    if (d56 < kMeet) return ArmSolver(model, ArmFamily::kOffsetWrist);
  }
  return std::nullopt;
}

ArmSolver::ArmSolver(const RobotModel& model, ArmFamily family) : model_(model), family_(family) {
  Axes(Eigen::VectorXd::Zero(6), axes0_, &T_base_tool0_);
  double distance = 0.0;
  // The wrist point: the wrist centre (axes 4, 5, 6 meet) carried by joint 4's frame, or where axes 5 and 6
  // meet, carried by joint 5's frame; both are fixed in that frame (they lie on its joint's axis).
  wrist_frame_ = family == ArmFamily::kSphericalWrist ? 3 : 4;
  wrist0_ = ClosestPoint(axes0_[4].p, axes0_[4].w, axes0_[5].p, axes0_[5].w, &distance);
  Transform frames[6], flange;
  NominalChainInBase(model_, Eigen::VectorXd::Zero(6), frames, &flange);
  wrist_local_ = frames[wrist_frame_].inverse() * wrist0_;
  const double reach = ShoulderReach(axes0_, wrist0_);
  shoulder_sign_ = reach < 0.0 ? -1.0 : 1.0;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  q[4] = std::numbers::pi / 2.0;
  Axis axes[6];
  Transform tool;
  Axes(q, axes, &tool);
  const double s = axes[4].w.dot(axes[3].w.cross(axes[5].w));
  wrist_sign_ = s < 0.0 ? -1.0 : 1.0;
}

void ArmSolver::Axes(const Eigen::VectorXd& q, Axis* axes, Transform* T_base_tool) const {
  Transform frames[6], flange;
  NominalChainInBase(model_, q, frames, &flange);
  for (int i = 0; i < 6; ++i) axes[i] = {frames[i].linear().col(2), frames[i].translation()};
  *T_base_tool = flange * model_.T_flange_tool();
}

double ArmSolver::ShoulderReach(const Axis* axes, const Eigen::Vector3d& wrist) const {
  return axes[0].w.cross(axes[1].w).normalized().dot(wrist - axes[0].p);
}

ArmConfiguration ArmSolver::Flags(const Axis* axes, const Eigen::Vector3d& wrist,
                                  const Eigen::Vector3d& elbow_end) const {
  ArmConfiguration c;
  const double reach = ShoulderReach(axes, wrist);
  c.shoulder = reach * shoulder_sign_ >= 0.0 ? 1 : -1;
  const Eigen::Vector3d z1 = axes[0].w, a = axes[1].w;
  // The arm plane: outward h (from axis 1 towards the wrist), up v (joint 1's axis within the plane).
  const Eigen::Vector3d h = (reach >= 0.0 ? 1.0 : -1.0) * z1.cross(a).normalized();
  const Eigen::Vector3d v = (z1 - a * a.dot(z1)).normalized();
  const Eigen::Vector3d shoulder = axes[1].p, elbow = axes[2].p;
  c.elbow = h.cross(v).dot((elbow_end - shoulder).cross(elbow - shoulder)) >= 0.0 ? 1 : -1;
  c.wrist = axes[4].w.dot(axes[3].w.cross(axes[5].w)) * wrist_sign_ >= 0.0 ? 1 : -1;
  return c;
}

ArmConfiguration ArmSolver::ConfigurationOf(const Eigen::VectorXd& q) const {
  Transform frames[6], flange;
  NominalChainInBase(model_, q, frames, &flange);
  Axis axes[6];
  for (int i = 0; i < 6; ++i) axes[i] = {frames[i].linear().col(2), frames[i].translation()};
  const Eigen::Vector3d wrist = frames[wrist_frame_] * wrist_local_;
  // The end of the planar chain of the parallel joints: the wrist centre, or (offset wrist) axis 4.
  const Eigen::Vector3d elbow_end = family_ == ArmFamily::kSphericalWrist ? wrist : axes[3].p;
  return Flags(axes, wrist, elbow_end);
}

std::vector<ArmSolution> ArmSolver::Solve(const Transform& T_base_tool, const Eigen::VectorXd& reference) const {
  const Axis* x = axes0_;
  auto exp = [&](int i, double angle) {
    Transform t = Transform::Identity();
    t.linear() = Rot(x[i].w, angle);
    t.translation() = x[i].p - t.linear() * x[i].p;
    return t;
  };
  // g = E1 ... E6 g0 with E_i = exp(joint i about its zero-configuration axis): G = g g0^-1.
  const Transform G = T_base_tool * T_base_tool0_.inverse();
  const Eigen::Vector3d a0 = x[1].w;  // the direction of the parallel joints
  std::vector<Eigen::VectorXd> raw;
  // The shoulder: the wrist point's component along the parallel axes does not change with them.
  const Eigen::Vector3d wrist_target = G * wrist0_;
  for (double q1 : RotateToDotOr(x[0].w, a0, wrist_target - x[0].p, a0.dot(wrist0_ - x[0].p), reference[0])) {
    const Transform E1 = exp(0, q1);
    if (family_ == ArmFamily::kSphericalWrist) {
      // Elbow: the distance from axis 2 to the wrist centre, then joint 2 turns it into place.
      const Eigen::Vector3d c1 = E1.inverse() * wrist_target;
      const Eigen::Vector3d u = wrist0_ - x[2].p, to2 = x[1].p - x[2].p;
      const double dot = (u.squaredNorm() + to2.squaredNorm() - (c1 - x[1].p).squaredNorm()) / 2.0;
      for (double q3 : RotateToDotOr(x[2].w, u, to2, dot, reference[2])) {
        const Transform E3 = exp(2, q3);
        const double q2 = RotateTo(x[1].w, E3 * wrist0_ - x[1].p, c1 - x[1].p).value_or(reference[1]);
        const Eigen::Matrix3d Rw = (E1 * exp(1, q2) * E3).linear().transpose() * G.linear();
        // Wrist: joint 5 sets the angle between axis 6 and axis 4, joint 4 turns axis 6 into place, joint 6 the rest.
        const Eigen::Vector3d v = Rw * x[5].w;
        for (double q5 : RotateToDotOr(x[4].w, x[5].w, x[3].w, x[3].w.dot(v), reference[4])) {
          const Eigen::Matrix3d R5 = Rot(x[4].w, q5);
          const double q4 = RotateTo(x[3].w, R5 * x[5].w, v).value_or(reference[3]);
          const Eigen::Matrix3d R6 = (Rot(x[3].w, q4) * R5).transpose() * Rw;
          const Eigen::Vector3d e = AnyPerpendicular(x[5].w);
          const double q6 = RotateTo(x[5].w, e, R6 * e).value_or(reference[5]);
          Eigen::VectorXd q(6);
          q << q1, q2, q3, q4, q5, q6;
          raw.push_back(q);
        }
      }
    } else {
      const Eigen::Matrix3d R = G.linear(), R1 = E1.linear();
      // Joint 5 sets the angle between axis 6 and the parallel axes; joint 6 then turns their direction into
      // place; the parallel joints' sum is what remains of the rotation.
      for (double q5 : RotateToDotOr(x[4].w, x[5].w, a0, (R1 * a0).dot(R * x[5].w), reference[4])) {
        const Eigen::Matrix3d R5 = Rot(x[4].w, q5);
        const Eigen::Vector3d from = R.transpose() * R1 * a0, to = R5.transpose() * a0;
        // Joint 6 turns the parallel axes' direction into place. Near the wrist singularity (axis 6 nearly
        // parallel to them) that direction barely leaves axis 6 and joint 6 is ill-determined, while axis 6's
        // offset from axis 4 still moves the elbow's target: then the reference value and every 30 deg are
        // tried as well, each giving its own elbow solutions (the calibrated model refines the nearest).
        std::vector<double> q6s;
        if (const std::optional<double> q6 = RotateTo(x[5].w, from, to)) q6s.push_back(*q6);
        const double off_axis = std::min((from - x[5].w * x[5].w.dot(from)).norm(), (to - x[5].w * x[5].w.dot(to)).norm());
        if (off_axis < kNearlyParallel) {
          q6s.push_back(reference[5]);
          for (int k = -5; k <= 6; ++k) q6s.push_back(WrapAngle(k * std::numbers::pi / 6.0));
        }
        for (double q6 : q6s) {
        const Transform E5 = exp(4, q5), E6 = exp(5, q6);
        const Eigen::Matrix3d M = R1.transpose() * R * E6.linear().transpose() * R5.transpose();
        const Eigen::Vector3d e = AnyPerpendicular(a0);
        const double sum = RotateTo(a0, e, M * e).value_or(0.0);
        // Axis 4's point, carried by joints 2 and 3 only: the planar elbow.
        const Transform G234 = E1.inverse() * G * E6.inverse() * E5.inverse();
        const Eigen::Vector3d t4 = G234 * x[3].p;
        const Eigen::Vector3d u = x[3].p - x[2].p, to2 = x[1].p - x[2].p;
        const double dot = (u.squaredNorm() + to2.squaredNorm() - (t4 - x[1].p).squaredNorm()) / 2.0;
        for (double q3 : RotateToDotOr(x[2].w, u, to2, dot, reference[2])) {
          const Transform E3 = exp(2, q3);
          const double q2 = RotateTo(x[1].w, E3 * x[3].p - x[1].p, t4 - x[1].p).value_or(reference[1]);
          Eigen::VectorXd q(6);
          q << q1, q2, q3, WrapAngle(sum - q2 - q3), q5, q6;
          raw.push_back(q);
        }
        }
      }
    }
  }
  // Each with how well the nominal chain reaches the pose (a pose just beyond reach leaves a small miss), once.
  std::vector<ArmSolution> solutions;
  for (const Eigen::VectorXd& q : raw) {
    Axis axes[6];
    Transform tool;
    Axes(q, axes, &tool);
    ArmSolution s{q, ConfigurationOf(q), (tool.translation() - T_base_tool.translation()).norm(),
                  RotationVector(T_base_tool.linear() * tool.linear().transpose()).norm()};
    if (s.position_error_mm > kSeedMm || s.orientation_error_rad > kSeedRad) continue;
    bool seen = false;
    for (const ArmSolution& other : solutions) seen = seen || (other.joints - q).cwiseAbs().maxCoeff() < 1e-12;
    if (!seen) solutions.push_back(std::move(s));
  }
  return solutions;
}

}  // namespace robocal

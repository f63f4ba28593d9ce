// The ISO 9283 pose test's poses and characteristics (iso9283.h; the formulas in docs/iso9283.md).
#include "robocal/core/iso9283.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "planning_internal.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Sample standard deviation (divisor n - 1) of values with mean `mean`; NaN for fewer than 2.
double SampleStd(const std::vector<double>& values, double mean) {
  if (values.size() < 2) return kNaN;
  double sum = 0.0;
  for (double v : values) sum += (v - mean) * (v - mean);
  return std::sqrt(sum / static_cast<double>(values.size() - 1));
}

double Mean(const std::vector<double>& values) {
  double sum = 0.0;
  for (double v : values) sum += v;
  return sum / static_cast<double>(values.size());
}

Iso9283PoseFigures PoseFigures(int pose, const std::vector<const Iso9283Shot*>& shots, bool orientation) {
  Iso9283PoseFigures f;
  f.pose = pose;
  f.cycles = static_cast<int>(shots.size());
  const double n = static_cast<double>(shots.size());
  std::vector<Eigen::Vector3d> d, angles;
  for (const Iso9283Shot* s : shots) {
    f.command_mm += s->commanded.translation() / n;
    d.push_back(s->attained.translation() - s->commanded.translation());
    f.ap_xyz_mm += d.back() / n;
    if (orientation) {
      angles.push_back(RotationVector(s->attained.linear() * s->commanded.linear().transpose()));
    }
  }
  f.ap_mm = f.ap_xyz_mm.norm();
  std::vector<double> l;
  for (const Eigen::Vector3d& dj : d) l.push_back((dj - f.ap_xyz_mm).norm());
  if (shots.size() >= 2) {
    f.mean_l_mm = Mean(l);
    f.s_l_mm = SampleStd(l, f.mean_l_mm);
    f.rp_l_mm = f.mean_l_mm + 3.0 * f.s_l_mm;
  }
  if (orientation) {
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<double> a;
      for (const Eigen::Vector3d& v : angles) a.push_back(v[axis]);
      f.ap_abc_rad[axis] = Mean(a);
      f.rp_abc_rad[axis] = 3.0 * SampleStd(a, f.ap_abc_rad[axis]);
    }
  }
  return f;
}

}  // namespace

std::array<Eigen::Vector3d, 8> CubeCorners(const Iso9283Cube& cube) {
  std::array<Eigen::Vector3d, 8> corners;
  const double h = 0.5 * cube.size_mm;
  for (int k = 0; k < 8; ++k) {
    corners[k] = cube.center_mm + h * Eigen::Vector3d((k & 1) ? 1.0 : -1.0, (k & 2) ? 1.0 : -1.0,
                                                      (k & 4) ? 1.0 : -1.0);
  }
  return corners;
}

std::array<Eigen::Vector3d, kIso9283Poses> Iso9283Positions(const Iso9283Cube& cube) {
  if (!cube.center_mm.allFinite() || !std::isfinite(cube.size_mm) || !(cube.size_mm > 0.0)) {
    throw std::invalid_argument("ISO 9283 cube: the centre must be finite and the size positive");
  }
  const double h = 0.5 * cube.size_mm;
  // The measuring plane's corners in the order of P2..P5: (-,-,+), (-,+,+), (+,+,-), (+,-,-).
  const Eigen::Vector3d signs[4] = {{-1, -1, 1}, {-1, 1, 1}, {1, 1, -1}, {1, -1, -1}};
  std::array<Eigen::Vector3d, kIso9283Poses> p;
  p[0] = cube.center_mm;
  for (int k = 0; k < 4; ++k) p[k + 1] = cube.center_mm + 0.8 * h * signs[k];
  return p;
}

std::array<Transform, kIso9283Poses> Iso9283Poses(const Iso9283Cube& cube, const Eigen::Matrix3d& orientation) {
  std::array<Transform, kIso9283Poses> poses;
  const auto positions = Iso9283Positions(cube);
  for (int k = 0; k < kIso9283Poses; ++k) {
    poses[k] = Transform::Identity();
    poses[k].linear() = orientation;
    poses[k].translation() = positions[k];
  }
  return poses;
}

namespace {

// The points a cube must hold: its five poses and its corners.
std::vector<Eigen::Vector3d> CubePoints(const Iso9283Cube& cube) {
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& p : Iso9283Positions(cube)) points.push_back(p);
  for (const Eigen::Vector3d& c : CubeCorners(cube)) points.push_back(c);
  return points;
}

// Whether the robot reaches the tool pose (point, orientation) exactly on `branch`, within its limits and the cell.
bool Reaches(const RobotModel& model, const ArmSolver& solver, const Eigen::Matrix3d& orientation,
             const Eigen::Vector3d& point, const ArmConfiguration& branch,
             const std::function<bool(const Eigen::VectorXd&)>& feasible, const Eigen::VectorXd& reference) {
  Transform pose = Transform::Identity();
  pose.linear() = orientation;
  pose.translation() = point;
  for (ArmSolution& s : solver.Solve(pose, reference)) {
    if (!(s.configuration == branch) || s.position_error_mm > 1e-6 || s.orientation_error_rad > 1e-9) continue;
    if (!planning_detail::ShiftIntoLimits(model, &s.joints)) continue;
    if (!feasible || feasible(s.joints)) return true;
  }
  return false;
}

}  // namespace

Iso9283CubeSearch LargestIso9283Cube(const RobotModel& model, const Eigen::Matrix3d& orientation,
                                     const Iso9283CubeSearchOptions& options) {
  const std::optional<ArmSolver> solver = ArmSolver::For(model);
  if (!solver) {
    throw std::invalid_argument("the largest ISO 9283 cube needs closed-form inverse kinematics (a 6R arm of a "
                                "known family); give the cube's centre and size");
  }
  if (options.centres < 1 || !(options.max_size_mm > 0.0) || !(options.resolution_mm > 0.0) ||
      !std::isfinite(options.max_size_mm) || !(options.resolution_mm <= options.max_size_mm)) {
    throw std::invalid_argument("cube search: centres >= 1 and 0 < resolution_mm <= max_size_mm");
  }
  if (!orientation.allFinite() || !(orientation.transpose() * orientation).isApprox(Eigen::Matrix3d::Identity(), 1e-6)) {
    throw std::invalid_argument("cube search: the orientation is not a rotation");
  }
  Iso9283CubeSearch out;
  Rng rng(options.seed);
  const Eigen::VectorXd reference = 0.5 * (model.lower_limits() + model.upper_limits());
  const Transform T_base_world = model.T_world_base().inverse();
  const auto holds = [&](const Iso9283Cube& cube, const ArmConfiguration& branch) {
    for (const Eigen::Vector3d& p : CubePoints(cube)) {
      if (!Reaches(model, *solver, orientation, p, branch, options.feasible, reference)) return false;
    }
    return true;
  };
  for (int c = 0; c < options.centres; ++c) {
    ++out.centres_tried;
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    const Eigen::Vector3d centre = T_base_world * ForwardKinematics(model, q).translation();
    // The branches the centre is reached on with the orientation.
    Transform pose = Transform::Identity();
    pose.linear() = orientation;
    pose.translation() = centre;
    std::vector<ArmConfiguration> branches;
    for (const ArmSolution& s : solver->Solve(pose, reference)) {
      if (std::find(branches.begin(), branches.end(), s.configuration) == branches.end()) {
        branches.push_back(s.configuration);
      }
    }
    for (const ArmConfiguration& branch : branches) {
      // A size only a larger cube than the best so far could beat is worth bisecting.
      const double floor = out.found ? out.cube.size_mm : 0.0;
      if (!holds({centre, floor + options.resolution_mm}, branch)) continue;
      double lo = floor + options.resolution_mm, hi = options.max_size_mm;
      if (holds({centre, hi}, branch)) lo = hi;
      while (hi - lo > options.resolution_mm) {
        const double mid = 0.5 * (lo + hi);
        (holds({centre, mid}, branch) ? lo : hi) = mid;
      }
      const double size = options.resolution_mm * std::floor(lo / options.resolution_mm);
      if (size > floor && holds({centre, size}, branch)) {
        out.found = true;
        out.cube = {centre, size};
        out.configuration = branch;
      }
    }
  }
  std::ostringstream m;
  if (out.found) {
    m << "the largest of " << out.centres_tried << " seeded centres: " << out.cube.size_mm << " mm on "
      << out.configuration.ToString();
  } else {
    m << "no cube of " << options.resolution_mm << " mm or more at " << out.centres_tried
      << " seeded centres: the orientation is out of reach (or the cell allows too little)";
  }
  out.message = m.str();
  return out;
}

std::string Iso9283PoseName(int pose) { return "P" + std::to_string(pose + 1); }

int Iso9283PoseIndex(const std::string& name) {
  for (int k = 0; k < kIso9283Poses; ++k) {
    if (name == Iso9283PoseName(k)) return k;
  }
  return -1;
}

Iso9283Result Iso9283Analyse(const std::vector<Iso9283Shot>& shots, bool orientation) {
  if (shots.empty()) throw std::invalid_argument("ISO 9283: no shots");
  // By pose, then by cycle: each (pose, cycle) once.
  std::map<int, std::map<int, const Iso9283Shot*>> by_pose;
  for (const Iso9283Shot& s : shots) {
    if (s.pose < 0 || s.pose >= kIso9283Poses) {
      throw std::invalid_argument("ISO 9283: pose index " + std::to_string(s.pose) + " is not one of P1..P5");
    }
    if (s.cycle < 1) throw std::invalid_argument("ISO 9283: cycle " + std::to_string(s.cycle) + " is below 1");
    if (!IsValidRigidTransform(s.attained, 1e-6) || !IsValidRigidTransform(s.commanded, 1e-6)) {
      throw std::invalid_argument("ISO 9283: " + Iso9283PoseName(s.pose) + " cycle " + std::to_string(s.cycle) +
                                  " is not a finite rigid pose");
    }
    if (!by_pose[s.pose].emplace(s.cycle, &s).second) {
      throw std::invalid_argument("ISO 9283: " + Iso9283PoseName(s.pose) + " cycle " + std::to_string(s.cycle) +
                                  " is given twice");
    }
  }
  Iso9283Result result;
  for (const auto& [pose, cycles] : by_pose) {
    std::vector<const Iso9283Shot*> list;
    for (const auto& entry : cycles) list.push_back(entry.second);
    result.poses.push_back(PoseFigures(pose, list, orientation));
    result.cycles = std::max(result.cycles, static_cast<int>(list.size()));
  }
  for (const auto& [from, to] : kIso9283DistancePairs) {
    const auto a = by_pose.find(from), b = by_pose.find(to);
    if (a == by_pose.end() || b == by_pose.end()) continue;
    Iso9283Distance dist;
    dist.from = from;
    dist.to = to;
    std::vector<double> deviation, command;
    std::vector<Eigen::Vector3d> deviation_xyz;
    for (const auto& [cycle, shot_from] : a->second) {
      const auto other = b->second.find(cycle);
      if (other == b->second.end()) continue;
      const Iso9283Shot* shot_to = other->second;
      const Eigen::Vector3d d = shot_from->attained.translation() - shot_to->attained.translation();
      const Eigen::Vector3d dc = shot_from->commanded.translation() - shot_to->commanded.translation();
      deviation.push_back(d.norm() - dc.norm());
      command.push_back(dc.norm());
      deviation_xyz.push_back(d - dc);
    }
    if (deviation.empty()) continue;
    dist.cycles = static_cast<int>(deviation.size());
    dist.command_mm = Mean(command);
    dist.ad_mm = Mean(deviation);
    for (const Eigen::Vector3d& v : deviation_xyz) dist.ad_xyz_mm += v / static_cast<double>(deviation_xyz.size());
    dist.rd_mm = 3.0 * SampleStd(deviation, dist.ad_mm);
    result.distances.push_back(dist);
  }
  return result;
}

}  // namespace robocal

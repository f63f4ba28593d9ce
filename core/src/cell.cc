// The cell: validation and precomputation (Build), and the feasibility of configurations (full report, fast
// decision, census). The model is described in cell.h and docs/cells.md.
#include "robocal/core/cell.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <stdexcept>

#include "robocal/core/geometry.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"
#include "robocal/core/units.h"

namespace robocal {
namespace {

// Closer to the tracker than this, a reflector is "at the tracker": not measured.
constexpr double kAtTrackerMm = 1e-3;


constexpr int kNumRules = 6;
constexpr CellRule kRules[kNumRules] = {CellRule::kJointRange, CellRule::kObstacle,  CellRule::kSelfCollision,
                                        CellRule::kDistance,   CellRule::kIncidence, CellRule::kBeam};

constexpr unsigned Bit(CellRule rule) { return 1u << static_cast<int>(rule); }

std::string Fixed(double value, int digits = 1) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
  return buffer;
}

// A joint value as a user reads it: degrees for a revolute joint, mm for a prismatic one.
std::string JointValue(const RobotModel& model, int joint, double value) {
  return model.joint_type(joint) == JointType::kRevolute ? Fixed(value * kDegPerRad) + " deg" : Fixed(value) + " mm";
}

std::string JointRange(const RobotModel& model, int joint, double lo, double hi) {
  const bool revolute = model.joint_type(joint) == JointType::kRevolute;
  const double scale = revolute ? kDegPerRad : 1.0;
  return "[" + Fixed(lo * scale) + ", " + Fixed(hi * scale) + "] " + (revolute ? "deg" : "mm");
}

// True when the bounding boxes of two segments, the second grown by `margin`, are apart: then the segments are
// more than `margin` apart (a cheap rejection before the exact distance).
bool BoundsApart(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, const Eigen::Vector3d& b_lo,
                 const Eigen::Vector3d& b_hi, double margin) {
  for (int k = 0; k < 3; ++k) {
    if (std::min(a0[k], a1[k]) > b_hi[k] + margin || std::max(a0[k], a1[k]) < b_lo[k] - margin) return true;
  }
  return false;
}

// A configuration's failed rules (CellKernel::Check), each with its sentences joined in the order they were found.
struct CellRuleSentences {
  std::vector<std::string> sentences = std::vector<std::string>(kNumRules);
  unsigned failed = 0;

  void Add(CellRule rule, const std::string& sentence) {
    std::string& s = sentences[static_cast<int>(rule)];
    s += (s.empty() ? "" : "; ") + sentence;
    failed |= Bit(rule);
  }
};

// The clearances of one kind of pair (capsule-obstacle or capsule-capsule) in one configuration: the smallest of
// every pair goes to the check, and the worst violation of the kind is explained.
class ClearanceTally {
 public:
  ClearanceTally(CellRule rule, double clearance_mm, ConfigurationCheck* check)
      : rule_(rule), clearance_mm_(clearance_mm), check_(check) {}

  void Consider(double gap, const std::string& a, const std::string& b) {
    if (gap < check_->min_clearance_mm) {
      check_->min_clearance_mm = gap;
      check_->clearance_pair = a + " / " + b;
    }
    if (gap < clearance_mm_) {
      ++violations_;
      if (gap < worst_) {
        worst_ = gap;
        worst_pair_ = rule_ == CellRule::kObstacle ? a + " and obstacle '" + b + "'" : a + " and " + b;
      }
    }
  }

  void Explain(const char* what, CellRuleSentences* sentences) const {
    if (violations_ == 0) return;
    std::string s = worst_ < 0.0 ? worst_pair_ + " overlap by " + Fixed(-worst_) + " mm"
                                 : worst_pair_ + " are " + Fixed(worst_) + " mm apart";
    s += ", under the " + Fixed(clearance_mm_) + " mm clearance";
    if (violations_ > 1) s += " (" + std::to_string(violations_) + " " + what + " too close)";
    sentences->Add(rule_, s);
  }

 private:
  const CellRule rule_;
  const double clearance_mm_;
  ConfigurationCheck* const check_;
  double worst_ = std::numeric_limits<double>::infinity();
  std::string worst_pair_;
  int violations_ = 0;
};

}  // namespace

// Everything that reads the cell's precomputed data; a friend of Cell.
struct CellKernel {
  // One configuration's geometry in the base frame, on the stack.
  struct Scene {
    int n = 0;
    Eigen::Vector3d point[kMaxJoints + 1];  // frame origins 0 (base) .. n (flange)
    Eigen::Vector3d reflector[kMaxReflectors];
    Eigen::Vector3d normal[kMaxReflectors];
    const Eigen::Vector3d& Start(int capsule) const { return capsule < n ? point[capsule] : point[n]; }
    const Eigen::Vector3d& End(int capsule) const { return capsule < n ? point[capsule + 1] : reflector[capsule - n]; }
  };

  // One reflector's three conditions.
  struct Sight {
    double distance_mm = 0.0;
    bool in_window = false;
    bool facing = false;
    int blocker = -1;  // -1: clear; a capsule index; num_capsules + an obstacle index
    bool measurable() const { return in_window && facing && blocker < 0; }
  };

  static int NumCapsules(const Cell& cell) { return static_cast<int>(cell.radius_mm_.size()); }

  static void CheckModel(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q) {
    if (model.num_joints() != cell.num_joints_) {
      throw std::invalid_argument("cell: built for a robot with " + std::to_string(cell.num_joints_) +
                                  " joints, used with '" + model.name() + "' (" + std::to_string(model.num_joints()) +
                                  " joints)");
    }
    if (q.size() != cell.num_joints_) {
      throw std::invalid_argument("cell: q has " + std::to_string(q.size()) + " values, the robot has " +
                                  std::to_string(cell.num_joints_) + " joints");
    }
  }

  static bool InRange(const Cell& cell, const Eigen::VectorXd& q, int joint) {
    return q[joint] >= cell.spec_.joint_min[joint] && q[joint] <= cell.spec_.joint_max[joint];  // NaN: false
  }

  static void ComputeScene(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q, Scene* scene) {
    const int n = model.num_joints();
    Transform T_base_joint[kMaxJoints];
    Transform T_base_flange;
    NominalChainInBase(model, q, T_base_joint, &T_base_flange);
    scene->n = n;
    scene->point[0].setZero();
    for (int k = 1; k < n; ++k) scene->point[k] = T_base_joint[k].translation();
    scene->point[n] = T_base_flange.translation();
    const auto& reflectors = cell.spec_.reflectors;
    for (size_t t = 0; t < reflectors.size(); ++t) {
      scene->reflector[t] = T_base_flange * reflectors[t].position_mm;
      scene->normal[t] = T_base_flange.linear() * reflectors[t].normal;
    }
  }

  // Distance window and acceptance cone (cheap).
  static void Aim(const Cell& cell, const Scene& scene, int t, Sight* sight) {
    const TrackerSpec& tracker = cell.spec_.tracker;
    const Eigen::Vector3d to_tracker = tracker.position_mm - scene.reflector[t];
    sight->distance_mm = to_tracker.norm();
    // A reflector at the tracker itself (within a micrometre) is not measured, nor has it a direction to face.
    sight->in_window = sight->distance_mm > kAtTrackerMm && sight->distance_mm >= tracker.min_distance_mm &&
                       sight->distance_mm <= tracker.max_distance_mm;
    // angle <= half angle  <=>  cos(angle) >= cos(half angle), without an acos per reflector.
    sight->facing = sight->distance_mm > kAtTrackerMm &&
                    scene.normal[t].dot(to_tracker) >= cell.cos_half_angle_[t] * sight->distance_mm;
  }

  // What the beam tracker -> reflector t passes through first in the order links, tool capsules, obstacles;
  // -1 if nothing. The reflector's own tool capsule is skipped: the reflector sits at its end.
  static int BeamBlocker(const Cell& cell, const Scene& scene, int t) {
    const Eigen::Vector3d& a = cell.spec_.tracker.position_mm;
    const Eigen::Vector3d& b = scene.reflector[t];
    const Eigen::Vector3d lo = a.cwiseMin(b), hi = a.cwiseMax(b);
    const int num_capsules = NumCapsules(cell);
    const int own = scene.n + t;
    for (int k = 0; k < num_capsules; ++k) {
      if (k == own) continue;
      const double r = cell.radius_mm_[k];
      if (BoundsApart(scene.Start(k), scene.End(k), lo, hi, r)) continue;
      if (SegmentHitsCapsule(a, b, scene.Start(k), scene.End(k), r)) return k;
    }
    const auto& obstacles = cell.spec_.obstacles;
    for (size_t o = 0; o < obstacles.size(); ++o) {
      if (SegmentIntersectsBox(a, b, obstacles[o].min_mm, obstacles[o].max_mm)) {
        return num_capsules + static_cast<int>(o);
      }
    }
    return -1;
  }

  // Surface distances (negative: overlap). Exact; callers that only need "below the clearance?" may skip a
  // pair first with BoundsApart.
  static double ObstacleGap(const Cell& cell, const Scene& scene, int capsule, const BoxObstacle& box) {
    return SegmentBoxDistance(scene.Start(capsule), scene.End(capsule), box.min_mm, box.max_mm) -
           cell.radius_mm_[capsule];
  }
  static double CapsuleGap(const Cell& cell, const Scene& scene, int i, int j) {
    return SegmentSegmentDistance(scene.Start(i), scene.End(i), scene.Start(j), scene.End(j)) - cell.radius_mm_[i] -
           cell.radius_mm_[j];
  }

  static bool ObstacleTooClose(const Cell& cell, const Scene& scene, int capsule, const BoxObstacle& box) {
    const double margin = cell.radius_mm_[capsule] + cell.spec_.clearance_mm;
    if (BoundsApart(scene.Start(capsule), scene.End(capsule), box.min_mm, box.max_mm, margin)) return false;
    return ObstacleGap(cell, scene, capsule, box) < cell.spec_.clearance_mm;
  }
  static bool CapsulesTooClose(const Cell& cell, const Scene& scene, int i, int j) {
    const double margin = cell.radius_mm_[i] + cell.radius_mm_[j] + cell.spec_.clearance_mm;
    const Eigen::Vector3d lo = scene.Start(j).cwiseMin(scene.End(j)), hi = scene.Start(j).cwiseMax(scene.End(j));
    if (BoundsApart(scene.Start(i), scene.End(i), lo, hi, margin)) return false;
    return CapsuleGap(cell, scene, i, j) < cell.spec_.clearance_mm;
  }

  static bool AnyObstacleTooClose(const Cell& cell, const Scene& scene) {
    for (const int k : cell.obstacle_capsules_) {
      for (const BoxObstacle& box : cell.spec_.obstacles) {
        if (ObstacleTooClose(cell, scene, k, box)) return true;
      }
    }
    return false;
  }
  static bool AnyCapsulesTooClose(const Cell& cell, const Scene& scene) {
    for (const auto& [i, j] : cell.capsule_pairs_) {
      if (CapsulesTooClose(cell, scene, i, j)) return true;
    }
    return false;
  }

  static bool IsFeasible(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q) {
    CheckModel(model, cell, q);
    for (int i = 0; i < cell.num_joints_; ++i) {
      if (!InRange(cell, q, i)) return false;
    }
    Scene scene;
    ComputeScene(model, cell, q, &scene);
    // The cheap conditions of every reflector first: they reject most configurations of a typical cell.
    const int num_reflectors = static_cast<int>(cell.spec_.reflectors.size());
    unsigned candidates = 0;
    for (int t = 0; t < num_reflectors; ++t) {
      Sight sight;
      Aim(cell, scene, t, &sight);
      if (sight.in_window && sight.facing) candidates |= 1u << t;
    }
    if (candidates == 0) return false;
    if (AnyObstacleTooClose(cell, scene) || AnyCapsulesTooClose(cell, scene)) return false;
    for (int t = 0; t < num_reflectors; ++t) {
      if ((candidates >> t & 1u) && BeamBlocker(cell, scene, t) < 0) return true;
    }
    return false;
  }

  // The rules one configuration fails, as bits; every rule evaluated, each until its first violation.
  static unsigned FailedRules(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q) {
    CheckModel(model, cell, q);
    unsigned failed = 0;
    for (int i = 0; i < cell.num_joints_; ++i) {
      if (!InRange(cell, q, i)) failed |= Bit(CellRule::kJointRange);
    }
    Scene scene;
    ComputeScene(model, cell, q, &scene);
    if (AnyObstacleTooClose(cell, scene)) failed |= Bit(CellRule::kObstacle);
    if (AnyCapsulesTooClose(cell, scene)) failed |= Bit(CellRule::kSelfCollision);
    failed |= SightRules(cell, scene, nullptr);
    return failed;
  }

  // kDistance / kIncidence / kBeam bits when no reflector is measurable; fills `sights` if given.
  static unsigned SightRules(const Cell& cell, const Scene& scene, Sight* sights) {
    const int num_reflectors = static_cast<int>(cell.spec_.reflectors.size());
    unsigned failed = 0;
    bool any_measurable = false;
    for (int t = 0; t < num_reflectors; ++t) {
      Sight sight;
      Aim(cell, scene, t, &sight);
      sight.blocker = BeamBlocker(cell, scene, t);
      any_measurable = any_measurable || sight.measurable();
      if (!sight.in_window) failed |= Bit(CellRule::kDistance);
      if (!sight.facing) failed |= Bit(CellRule::kIncidence);
      if (sight.blocker >= 0) failed |= Bit(CellRule::kBeam);
      if (sights != nullptr) sights[t] = sight;
    }
    return any_measurable ? 0u : failed;
  }

  static std::string BlockerName(const Cell& cell, int blocker) {
    if (blocker < 0) return "";
    const int num_capsules = NumCapsules(cell);
    return blocker < num_capsules ? cell.capsule_names_[blocker] : cell.spec_.obstacles[blocker - num_capsules].id;
  }

  static ConfigurationCheck Check(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q);
  static void CheckClearances(const Cell& cell, const Scene& scene, ConfigurationCheck* check,
                              CellRuleSentences* sentences);
  static void CheckReflectors(const Cell& cell, const Scene& scene, ConfigurationCheck* check,
                              CellRuleSentences* sentences);
  static void Precompute(const RobotModel& model, Cell* cell);
};

ConfigurationCheck CellKernel::Check(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q) {
  CheckModel(model, cell, q);
  const CellSpec& spec = cell.spec_;
  ConfigurationCheck check;
  CellRuleSentences sentences;
  for (int i = 0; i < cell.num_joints_; ++i) {
    if (InRange(cell, q, i)) continue;
    sentences.Add(CellRule::kJointRange, model.joint_name(i) + " is at " + JointValue(model, i, q[i]) +
                                             ", outside the cell's range " +
                                             JointRange(model, i, spec.joint_min[i], spec.joint_max[i]));
  }
  Scene scene;
  ComputeScene(model, cell, q, &scene);
  CheckClearances(cell, scene, &check, &sentences);
  CheckReflectors(cell, scene, &check, &sentences);
  for (const CellRule rule : kRules) {
    if (!(sentences.failed & Bit(rule))) continue;
    check.failed_rules.push_back(rule);
    check.reasons.push_back(sentences.sentences[static_cast<int>(rule)]);
  }
  check.feasible = sentences.failed == 0;
  return check;
}

// Clearances: every checked pair, the smallest reported, the worst violation of each kind explained.
void CellKernel::CheckClearances(const Cell& cell, const Scene& scene, ConfigurationCheck* check,
                                 CellRuleSentences* sentences) {
  const CellSpec& spec = cell.spec_;
  ClearanceTally obstacles(CellRule::kObstacle, spec.clearance_mm, check);
  for (const int k : cell.obstacle_capsules_) {
    for (const BoxObstacle& box : spec.obstacles) {
      obstacles.Consider(ObstacleGap(cell, scene, k, box), cell.capsule_names_[k], box.id);
    }
  }
  obstacles.Explain("capsule-obstacle pairs", sentences);
  ClearanceTally self(CellRule::kSelfCollision, spec.clearance_mm, check);
  for (const auto& [i, j] : cell.capsule_pairs_) {
    self.Consider(CapsuleGap(cell, scene, i, j), cell.capsule_names_[i], cell.capsule_names_[j]);
  }
  self.Explain("capsule pairs", sentences);
}

// Reflectors: each one's figures, and why the ones the tracker cannot measure fail (when none can be).
void CellKernel::CheckReflectors(const Cell& cell, const Scene& scene, ConfigurationCheck* check,
                                 CellRuleSentences* sentences) {
  const CellSpec& spec = cell.spec_;
  const int num_reflectors = static_cast<int>(spec.reflectors.size());
  Sight sights[kMaxReflectors];
  const unsigned sight_failed = SightRules(cell, scene, sights);
  for (int t = 0; t < num_reflectors; ++t) {
    const ReflectorSpec& reflector = spec.reflectors[t];
    ReflectorCheck r;
    r.id = reflector.id;
    r.measurable = sights[t].measurable();
    r.incidence_rad = IncidenceAngle(scene.normal[t], scene.reflector[t], spec.tracker.position_mm);
    r.distance_mm = sights[t].distance_mm;
    r.blocked_by = BlockerName(cell, sights[t].blocker);
    check->reflectors.push_back(r);
    if (sight_failed == 0) continue;
    if (!sights[t].in_window) {
      std::string window =
          "[" + Fixed(spec.tracker.min_distance_mm) + ", " +
          (std::isinf(spec.tracker.max_distance_mm) ? std::string("inf") : Fixed(spec.tracker.max_distance_mm)) +
          "] mm";
      sentences->Add(CellRule::kDistance, r.distance_mm > kAtTrackerMm
                                              ? reflector.id + " is " + Fixed(r.distance_mm) +
                                                    " mm from the tracker, outside its window " + window
                                              : reflector.id + " is at the tracker itself");
    }
    if (!sights[t].facing) {
      sentences->Add(CellRule::kIncidence, reflector.id + " faces " + Fixed(r.incidence_rad * kDegPerRad) +
                                               " deg away from the tracker, beyond its acceptance of " +
                                               Fixed(reflector.acceptance_half_angle_rad * kDegPerRad) + " deg");
    }
    if (sights[t].blocker >= 0) {
      sentences->Add(CellRule::kBeam, "the beam to " + reflector.id + " is blocked by " + r.blocked_by);
    }
  }
}

void CellKernel::Precompute(const RobotModel& model, Cell* cell) {
  const CellSpec& spec = cell->spec_;
  const int n = model.num_joints();
  const int num_reflectors = static_cast<int>(spec.reflectors.size());
  cell->num_joints_ = n;
  cell->radius_mm_ = spec.link_radii_mm;
  for (int k = 0; k < n; ++k) cell->capsule_names_.push_back("link " + std::to_string(k + 1));
  for (const ReflectorSpec& r : spec.reflectors) {
    cell->radius_mm_.push_back(spec.tool_radius_mm);
    cell->capsule_names_.push_back(r.id == "tool" ? "tool" : "tool " + r.id);  // the default reflector: "tool"
    cell->cos_half_angle_.push_back(std::cos(r.acceptance_half_angle_rad));
  }

  // Which link capsules move: compare their ends over the corners, the middle and a few seeded draws of the
  // ranges. Which link lengths can shrink: link k's length depends on q_k alone (the origin of frame k - 1 is
  // on joint k's axis, or is the base), so a sweep of q_k finds its shortest length.
  const Eigen::VectorXd mid = 0.5 * (spec.joint_min + spec.joint_max);
  std::vector<Eigen::VectorXd> probes = {mid, spec.joint_min, spec.joint_max};
  Rng rng(20240613);
  for (int s = 0; s < 5; ++s) {
    Eigen::VectorXd q(n);
    for (int i = 0; i < n; ++i) q[i] = rng.Uniform(spec.joint_min[i], spec.joint_max[i]);
    probes.push_back(q);
  }
  Scene reference, scene;
  ComputeScene(model, *cell, mid, &reference);
  std::vector<bool> moves(n, false);
  for (const Eigen::VectorXd& q : probes) {
    ComputeScene(model, *cell, q, &scene);
    for (int k = 0; k < n; ++k) {
      moves[k] = moves[k] || (scene.point[k] - reference.point[k]).norm() > 1e-6 ||
                 (scene.point[k + 1] - reference.point[k + 1]).norm() > 1e-6;
    }
  }
  for (int k = 0; k < n + num_reflectors; ++k) {
    if (k >= n || moves[k]) cell->obstacle_capsules_.push_back(k);
  }
  std::vector<double> shortest(n, std::numeric_limits<double>::infinity());
  constexpr int kSweep = 64;
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd q = mid;
    for (int s = 0; s <= kSweep; ++s) {
      q[k] = spec.joint_min[k] + (spec.joint_max[k] - spec.joint_min[k]) * s / kSweep;
      ComputeScene(model, *cell, q, &scene);
      shortest[k] = std::min(shortest[k], (scene.point[k + 1] - scene.point[k]).norm());
    }
  }

  // Capsule pairs: a tool capsule sits at chain position n, after the last link.
  auto position = [n](int capsule) { return std::min(capsule, n); };
  for (int i = 0; i < n + num_reflectors; ++i) {
    for (int j = i + 1; j < n + num_reflectors; ++j) {
      if (position(j) - position(i) <= 1) continue;
      double between = 0.0;
      for (int k = position(i) + 1; k < position(j); ++k) between += shortest[k];
      const double touching = cell->radius_mm_[i] + cell->radius_mm_[j] + spec.clearance_mm;
      if (between <= touching + 1e-6) continue;  // they touch by construction
      cell->capsule_pairs_.emplace_back(i, j);
    }
  }
}

const char* ToString(CellRule rule) {
  switch (rule) {
    case CellRule::kJointRange:
      return "joint_range";
    case CellRule::kObstacle:
      return "obstacle";
    case CellRule::kSelfCollision:
      return "self_collision";
    case CellRule::kDistance:
      return "distance";
    case CellRule::kIncidence:
      return "incidence";
    case CellRule::kBeam:
      return "beam";
  }
  return "?";
}

std::vector<double> DefaultLinkRadii(const RobotModel& model) {
  // Envelopes of the preset arms' links as capsules around the frame-origin polyline (docs/cells.md gives
  // the reasoning). They are estimates, not datasheet values, and they leave the wrists' fixed spacing room
  // for a 20 mm clearance.
  const int n = model.num_joints();
  if (model.name() == "ur5e" && n == 6) return {60, 50, 40, 35, 35, 30};
  if (model.name() == "puma560" && n == 6) return {70, 60, 50, 45, 40, 35};
  if (model.name() == "grinder5" && n == 5) return {40, 40, 50, 50, 40};
  Transform T_base_joint[kMaxJoints];
  Transform T_base_flange;
  const Eigen::VectorXd mid = 0.5 * (model.lower_limits() + model.upper_limits());
  NominalChainInBase(model, mid, T_base_joint, &T_base_flange);
  double length = 0.0;
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (int k = 1; k <= n; ++k) {
    const Eigen::Vector3d point = k < n ? T_base_joint[k].translation() : T_base_flange.translation();
    length += (point - previous).norm();
    previous = point;
  }
  return std::vector<double>(n, std::clamp(length / 25.0, 10.0, 50.0));
}

namespace {

// The checks of Cell::Build, each collecting the errors of its fields.
class CellSpecCheck {
 public:
  explicit CellSpecCheck(const RobotModel& model) : model_(model) {}

  void Tracker(const TrackerSpec& tracker) {
    if (!tracker.position_mm.allFinite()) Error("tracker.position_mm", kFinite);
    const bool min_ok = std::isfinite(tracker.min_distance_mm) && tracker.min_distance_mm >= 0.0;
    if (!min_ok) Error("tracker.min_distance_mm", "must be a finite number >= 0");
    if (std::isnan(tracker.max_distance_mm) || (std::isinf(tracker.max_distance_mm) && tracker.max_distance_mm < 0.0)) {
      Error("tracker.max_distance_mm", "must be a number (or +infinity: no limit)");
    } else if (min_ok && !(tracker.max_distance_mm > tracker.min_distance_mm)) {
      Error("tracker.max_distance_mm", "must be greater than min_distance_mm (" + Fixed(tracker.min_distance_mm) +
                                           " mm), got " + Fixed(tracker.max_distance_mm) + " mm");
    }
  }

  void Reflectors(const std::vector<ReflectorSpec>& reflectors) {
    if (reflectors.size() > static_cast<size_t>(kMaxReflectors)) {
      Error("reflectors",
            "at most " + std::to_string(kMaxReflectors) + " reflectors, got " + std::to_string(reflectors.size()));
    }
    std::set<std::string> ids;
    for (size_t t = 0; t < reflectors.size(); ++t) {
      const ReflectorSpec& r = reflectors[t];
      const std::string prefix = "reflectors[" + std::to_string(t) + "]";
      if (r.id.empty()) {
        Error(prefix + ".id", "must not be empty");
      } else if (!ids.insert(r.id).second) {
        Error(prefix + ".id", "duplicate reflector id '" + r.id + "'");
      }
      if (!r.position_mm.allFinite()) Error(prefix + ".position_mm", kFinite);
      if (!r.normal.allFinite()) {
        Error(prefix + ".normal", kFinite);
      } else if (std::abs(r.normal.norm() - 1.0) > 1e-6) {
        Error(prefix + ".normal", "must be a unit vector, its norm is " + Fixed(r.normal.norm(), 6));
      }
      if (!(r.acceptance_half_angle_rad > 0.0 && r.acceptance_half_angle_rad <= M_PI)) {
        Error(prefix + ".acceptance_half_angle_deg",
              "must be in (0, 180] degrees, got " + Fixed(r.acceptance_half_angle_rad * kDegPerRad));
      }
    }
  }

  void Obstacles(const std::vector<BoxObstacle>& obstacles) {
    std::set<std::string> ids;
    for (size_t o = 0; o < obstacles.size(); ++o) {
      const BoxObstacle& box = obstacles[o];
      const std::string prefix = "obstacles[" + std::to_string(o) + "]";
      if (box.id.empty()) {
        Error(prefix + ".id", "must not be empty");
      } else if (!ids.insert(box.id).second) {
        Error(prefix + ".id", "duplicate obstacle id '" + box.id + "'");
      }
      if (!box.min_mm.allFinite() || !box.max_mm.allFinite()) {
        Error(prefix + ".box", kFinite);
        continue;
      }
      for (int k = 0; k < 3; ++k) {
        if (box.min_mm[k] > box.max_mm[k]) {
          Error(prefix + ".box", std::string("min_mm must not exceed max_mm (") + "xyz"[k] + ": " +
                                     Fixed(box.min_mm[k]) + " > " + Fixed(box.max_mm[k]) + ")");
          break;
        }
      }
    }
  }

  // The links' and the tool's radii, and the clearance.
  void Links(const CellSpec& spec) {
    const int n = model_.num_joints();
    if (!spec.link_radii_mm.empty() && static_cast<int>(spec.link_radii_mm.size()) != n) {
      Error("link_radii_mm",
            "needs one radius per link (" + std::to_string(n) + "), got " + std::to_string(spec.link_radii_mm.size()));
    }
    for (size_t k = 0; k < spec.link_radii_mm.size(); ++k) {
      if (!(std::isfinite(spec.link_radii_mm[k]) && spec.link_radii_mm[k] >= 0.0)) {
        Error("link_radii_mm[" + std::to_string(k) + "]", "must be a finite number >= 0");
      }
    }
    if (!std::isfinite(spec.tool_radius_mm)) Error("tool_radius_mm", "must be a finite number");
    if (!(std::isfinite(spec.clearance_mm) && spec.clearance_mm >= 0.0)) {
      Error("clearance_mm", "must be a finite number >= 0");
    }
  }

  // The joint ranges given (one per joint, within the robot's limits), clamped to the limits where they exceed
  // them by round-off.
  void JointRanges(CellSpec* spec) {
    const int n = model_.num_joints();
    if (spec->joint_min.size() != n || spec->joint_max.size() != n) {
      Error("joint_ranges", "needs one range per joint (" + std::to_string(n) + "), got " +
                                std::to_string(std::max(spec->joint_min.size(), spec->joint_max.size())));
      return;
    }
    for (int i = 0; i < n; ++i) {
      const std::string field = "joint_ranges[" + std::to_string(i) + "]";
      double& lo = spec->joint_min[i];
      double& hi = spec->joint_max[i];
      const double lower = model_.lower_limits()[i], upper = model_.upper_limits()[i];
      if (!std::isfinite(lo) || !std::isfinite(hi)) {
        Error(field, "min and max must be finite numbers");
      } else if (!(lo < hi)) {
        Error(field, "min must be less than max, got " + JointRange(model_, i, lo, hi));
      } else if (lo < lower - 1e-9 * std::max(1.0, std::abs(lower)) ||
                 hi > upper + 1e-9 * std::max(1.0, std::abs(upper))) {
        Error(field, JointRange(model_, i, lo, hi) + " must lie within the robot's limits " +
                         JointRange(model_, i, lower, upper));
      } else {
        lo = std::max(lo, lower);
        hi = std::min(hi, upper);
      }
    }
  }

  void TrackerOutsideObstacles(const CellSpec& spec) {
    if (!spec.tracker.position_mm.allFinite()) return;
    for (const BoxObstacle& box : spec.obstacles) {
      if (box.min_mm.allFinite() && box.max_mm.allFinite() &&
          PointBoxDistance(spec.tracker.position_mm, box.min_mm, box.max_mm) == 0.0) {
        Error("tracker.position_mm", "lies in obstacle '" + box.id + "': every beam would be blocked");
      }
    }
  }

  // A reflector inside another one's tool capsule could never be seen: refuse it now rather than report it
  // blocked in every configuration.
  void ReflectorsOutsideToolCapsules(const CellSpec& spec) {
    for (size_t t = 0; t < spec.reflectors.size(); ++t) {
      for (size_t u = 0; u < spec.reflectors.size(); ++u) {
        if (u == t) continue;
        const double d = PointSegmentDistance(spec.reflectors[t].position_mm, Eigen::Vector3d::Zero(),
                                              spec.reflectors[u].position_mm);
        if (d < spec.tool_radius_mm) {
          Error("reflectors[" + std::to_string(t) + "].position_mm",
                "lies " + Fixed(d) + " mm from the axis of reflector '" + spec.reflectors[u].id +
                    "'s tool capsule (tool_radius_mm " + Fixed(spec.tool_radius_mm) + "): it could never be seen");
        }
      }
    }
  }

  void ThrowIfAny() {
    if (!errors_.empty()) throw InvalidModelError(std::move(errors_));
  }

 private:
  static constexpr const char* kFinite = "must contain only finite numbers";

  void Error(const std::string& field, const std::string& reason) { errors_.push_back({field, reason}); }

  const RobotModel& model_;
  std::vector<FieldError> errors_;
};

// Defaults: the tool's own reflector, link radii from the robot's size, the tool radius of the last link, the
// robot's limits as the joint ranges.
void AddCellDefaults(const RobotModel& model, bool no_ranges, CellSpec* spec) {
  if (spec->reflectors.empty()) {
    ReflectorSpec tool;
    tool.id = "tool";
    tool.position_mm = model.T_flange_tool().translation();
    tool.normal = model.T_flange_tool().linear().col(2).normalized();
    spec->reflectors.push_back(tool);
  }
  if (spec->link_radii_mm.empty()) spec->link_radii_mm = DefaultLinkRadii(model);
  if (spec->tool_radius_mm <= 0.0) spec->tool_radius_mm = spec->link_radii_mm.back();
  if (no_ranges) {
    spec->joint_min = model.lower_limits();
    spec->joint_max = model.upper_limits();
  }
}

}  // namespace

Cell Cell::Build(const RobotModel& model, CellSpec spec) {
  CellSpecCheck check(model);
  check.Tracker(spec.tracker);
  check.Reflectors(spec.reflectors);
  check.Obstacles(spec.obstacles);
  check.Links(spec);
  const bool no_ranges = spec.joint_min.size() == 0 && spec.joint_max.size() == 0;
  if (!no_ranges) check.JointRanges(&spec);
  check.TrackerOutsideObstacles(spec);
  check.ThrowIfAny();

  AddCellDefaults(model, no_ranges, &spec);
  check.ReflectorsOutsideToolCapsules(spec);
  check.ThrowIfAny();

  Cell cell;
  cell.spec_ = std::move(spec);
  CellKernel::Precompute(model, &cell);
  return cell;
}

RobotModel Cell::PlanningModel(const RobotModel& model) const {
  if (model.num_joints() != num_joints_) {
    throw std::invalid_argument("Cell::PlanningModel: the cell was built for a robot with " +
                                std::to_string(num_joints_) + " joints, '" + model.name() + "' has " +
                                std::to_string(model.num_joints()));
  }
  RobotModelSpec planning = model.spec();
  for (int i = 0; i < num_joints_; ++i) {
    planning.joints[i].min = spec_.joint_min[i];
    planning.joints[i].max = spec_.joint_max[i];
  }
  return RobotModel::Build(planning);
}

ConfigurationCheck CheckConfiguration(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q) {
  return CellKernel::Check(model, cell, q);
}

bool IsFeasible(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q) {
  return CellKernel::IsFeasible(model, cell, q);
}

FeasibilityCensus SampleFeasibility(const RobotModel& model, const Cell& cell, int samples, std::uint64_t seed) {
  if (samples <= 0) throw std::invalid_argument("SampleFeasibility: samples must be positive");
  const CellSpec& spec = cell.spec();
  if (model.num_joints() != spec.joint_min.size()) {
    throw std::invalid_argument("SampleFeasibility: the cell was built for a robot with " +
                                std::to_string(spec.joint_min.size()) + " joints, '" + model.name() + "' has " +
                                std::to_string(model.num_joints()));
  }
  FeasibilityCensus census;
  census.samples = samples;
  int counts[kNumRules] = {};
  Rng rng(seed);
  Eigen::VectorXd q(model.num_joints());
  for (int s = 0; s < samples; ++s) {
    for (int i = 0; i < q.size(); ++i) q[i] = rng.Uniform(spec.joint_min[i], spec.joint_max[i]);
    const unsigned failed = CellKernel::FailedRules(model, cell, q);
    if (failed == 0) ++census.feasible;
    for (int r = 0; r < kNumRules; ++r) counts[r] += (failed >> r) & 1u;
  }
  for (int r = 0; r < kNumRules; ++r) {
    census.rejected_by.emplace_back(kRules[r], counts[r]);
    if (counts[r] > counts[static_cast<int>(census.dominant)]) census.dominant = kRules[r];
  }
  census.dominant_share = static_cast<double>(counts[static_cast<int>(census.dominant)]) / samples;
  return census;
}

}  // namespace robocal

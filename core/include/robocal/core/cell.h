// A measurement cell: where the laser tracker stands, the reflectors on the tool, the obstacles around the robot,
// the robot's links as capsules, and the joint ranges allowed for planning. Feasibility of one configuration:
// within the ranges, no collision (obstacles, non-adjacent links), and at least one reflector measurable
// (distance window, acceptance angle, an unblocked beam). Everything in the robot's base frame (mm, rad) unless
// said otherwise; see docs/cells.md.
//
// Capsules. With n joints there are n link capsules, numbered 1..n in names ("link 3"): link k runs from the
// origin of frame k - 1 to the origin of frame k, where frame 0 is the base, frame k (0 < k < n) is joint k + 1's
// frame (the frame it turns in, before its motion: standard DH frame k) and frame n is the flange. Link k is
// the body joint k moves. Then one tool capsule per reflector ("tool smr1"; the default reflector's: "tool"),
// from the flange origin to the reflector.
//
// Which pairs are checked. Obstacles: every capsule that moves (a capsule no joint moves, such as the base
// column of most arms, stands on the robot's mount and is not checked against obstacles). Capsules among
// themselves: pairs that are not adjacent in the chain (links k and k + 1, the last link and every tool
// capsule, tool capsules among themselves are adjacent), and whose links in between are longer than the two
// radii plus the clearance: shorter ones make the pair touch by construction (a spherical wrist's zero-length
// links; the UR5e's link 4 and link 6, 99.7 mm apart), so checking them would reject every configuration.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"

namespace robocal {

/// At most this many reflectors per cell (feasibility checks keep per-reflector data on the stack).
inline constexpr int kMaxReflectors = 16;

struct TrackerSpec {
  /// The tracker's beam origin, base frame.
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  /// Distances at which it measures (its datasheet's window): finite, >= 0, min < max; max may be +infinity
  /// (no upper limit).
  double min_distance_mm = 0.0;
  double max_distance_mm = std::numeric_limits<double>::infinity();
};

/// A reflector (SMR in a nest, or a probe) on the tool: position and facing direction in the FLANGE frame.
struct ReflectorSpec {
  /// Non-empty, unique within the cell.
  std::string id;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  /// Unit vector (norm within 1e-6 of 1; Build refuses others rather than normalising a typo): the direction
  /// the reflector faces.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  /// The beam must arrive within this angle of the normal (a 1.5" red-ring SMR: about 30 degrees); (0, pi].
  double acceptance_half_angle_rad = 0.5235987755982988;
};

/// An axis-aligned box, base frame (min_mm <= max_mm on every axis).
struct BoxObstacle {
  /// Non-empty, unique within the cell; names the box in blocked_by and clearance_pair.
  std::string id;
  Eigen::Vector3d min_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_mm = Eigen::Vector3d::Zero();
};

struct CellSpec {
  TrackerSpec tracker;
  /// Empty: one reflector "tool" at the model's tool point, facing along the tool z axis.
  std::vector<ReflectorSpec> reflectors;
  std::vector<BoxObstacle> obstacles;
  /// One radius (>= 0) per link capsule (num_joints), link 1 first (see the top of this file). Empty:
  /// DefaultLinkRadii(model).
  std::vector<double> link_radii_mm;
  /// The tool capsules (flange -> each reflector); <= 0: the last link's radius.
  double tool_radius_mm = 0.0;
  /// Capsules must keep this distance (>= 0) from obstacles and from non-adjacent capsules: a surface distance
  /// below it rejects the configuration.
  double clearance_mm = 0.0;
  /// Joint ranges for planning (core units: rad / mm); both empty: the model's limits. Must lie within them
  /// (to 1e-9, for ranges converted from degrees; they are then clamped to the limits).
  Eigen::VectorXd joint_min;
  Eigen::VectorXd joint_max;
};

/// A documented default per preset (docs/cells.md; by the model's name and joint count), and for other robots
/// one radius for every link: the sum of the link lengths / 25, clamped to [10, 50] mm.
std::vector<double> DefaultLinkRadii(const RobotModel& model);

/// What a cell can reject a configuration for (the FAILED_PRECONDITION of an infeasible cell names the rule that
/// rejects most sampled configurations). The last three apply when no reflector is measurable; each names a
/// condition that stops at least one reflector (with one reflector: the conditions it fails).
enum class CellRule {
  kJointRange,
  kObstacle,       ///< a capsule within clearance_mm of an obstacle
  kSelfCollision,  ///< two non-adjacent capsules within clearance_mm
  kDistance,       ///< a reflector outside the tracker's distance window
  kIncidence,      ///< a reflector not facing the tracker within its acceptance angle
  kBeam,           ///< a reflector whose beam is blocked
};
/// "joint_range", "obstacle", "self_collision", "distance", "incidence", "beam".
const char* ToString(CellRule rule);

struct ReflectorCheck {
  std::string id;
  bool measurable = false;
  /// Angle between the reflector's normal and the direction to the tracker (rad).
  double incidence_rad = 0.0;
  double distance_mm = 0.0;
  /// What blocks the beam, whatever the other conditions: "link 3", "tool smr2" (another reflector's tool
  /// capsule; a reflector's own is never in its way), an obstacle's id; empty if nothing. With several
  /// blockers the first in the order links, tool capsules, obstacles.
  std::string blocked_by;
};

struct ConfigurationCheck {
  bool feasible = false;
  std::vector<ReflectorCheck> reflectors;
  /// The smallest surface distance between a capsule and an obstacle or a non-adjacent capsule (negative:
  /// overlap; infinite when no pair is checked), and the pair that sets it (e.g. "link 2 / floor",
  /// "link 1 / link 4").
  double min_clearance_mm = std::numeric_limits<double>::infinity();
  std::string clearance_pair;
  /// The rules it fails (empty when feasible), each once in enum order, and reasons[k] a sentence explaining
  /// failed_rules[k] (angles in degrees, lengths in mm).
  std::vector<CellRule> failed_rules;
  std::vector<std::string> reasons;
};

/// A validated cell for one model: use it only with that model (the functions below throw
/// std::invalid_argument when the joint count differs).
class Cell {
 public:
  /// Checks sizes and values and throws InvalidModelError naming every bad field as the wire does:
  /// "tracker.position_mm" (also: inside an obstacle), "tracker.min_distance_mm", "tracker.max_distance_mm",
  /// "reflectors" (too many), "reflectors[0].id", "reflectors[0].position_mm" (also: inside another reflector's
  /// tool capsule), "reflectors[0].normal", "reflectors[0].acceptance_half_angle_deg", "obstacles[1].id",
  /// "obstacles[1].box", "link_radii_mm" (count), "link_radii_mm[2]", "tool_radius_mm", "clearance_mm",
  /// "joint_ranges" (count), "joint_ranges[3]".
  static Cell Build(const RobotModel& model, CellSpec spec);
  /// The validated spec with every default filled in: reflectors, link_radii_mm, tool_radius_mm (> 0 unless
  /// the last radius is 0), joint_min / joint_max.
  const CellSpec& spec() const { return spec_; }
  /// The model's joint limits narrowed to the cell's joint ranges (for planners' sampling).
  RobotModel PlanningModel(const RobotModel& model) const;

 private:
  friend struct CellKernel;  // cell.cc: the checks read the precomputed data below
  Cell() = default;

  CellSpec spec_;
  int num_joints_ = 0;
  /// Per capsule, links 1..n then one tool capsule per reflector: radius and name ("link 1", "tool smr1").
  std::vector<double> radius_mm_;
  std::vector<std::string> capsule_names_;
  /// Capsules checked against obstacles (those that move), and the capsule pairs checked against each other.
  std::vector<int> obstacle_capsules_;
  std::vector<std::pair<int, int>> capsule_pairs_;
  /// Per reflector, cos(acceptance_half_angle_rad).
  std::vector<double> cos_half_angle_;
};

/// Full report of one configuration (core joint units). Throws std::invalid_argument if q does not have
/// num_joints values.
ConfigurationCheck CheckConfiguration(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q);
/// The same decision without the report, as fast as possible (planners call it per candidate): early exits, no
/// allocation.
bool IsFeasible(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q);

/// How much of the joint ranges a cell leaves feasible: `samples` (> 0, else std::invalid_argument) uniform
/// configurations within the ranges (seeded; the same draws as RandomConfiguration on the PlanningModel), how
/// many are feasible, and per rule how many it rejects (a configuration counts for every rule it fails).
struct FeasibilityCensus {
  int samples = 0;
  int feasible = 0;
  std::vector<std::pair<CellRule, int>> rejected_by;  // every rule, in enum order
  /// The rule rejecting most (ties: the first in enum order; none: kJointRange), and its share of the samples.
  CellRule dominant = CellRule::kJointRange;
  double dominant_share = 0.0;
};
FeasibilityCensus SampleFeasibility(const RobotModel& model, const Cell& cell, int samples, std::uint64_t seed);

/// The preset cell of a robot preset (docs/cells.md, "Preset cells"): a laser tracker a few metres away at a
/// tripod's height with a 1.5 .. 15 m window, the floor and a table as boxes, the default reflector (at the
/// tool point, facing along the tool's z axis, +-30 degrees), the default link radii, a 20 mm clearance and
/// the robot's full joint ranges. Build it with the preset's model. Throws std::invalid_argument when `robot`
/// is not a preset.
CellSpec PresetCellSpec(const std::string& robot);

}  // namespace robocal

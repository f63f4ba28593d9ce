// A measurement cell: where the laser tracker stands, the reflectors on the tool, the obstacles around the robot,
// the robot's links as capsules, and the joint ranges allowed for planning. Feasibility of one configuration:
// within the ranges, no collision (obstacles, non-adjacent links), and at least one reflector measurable
// (distance window, acceptance angle, an unblocked beam). Everything in the robot's base frame (mm, rad) unless
// said otherwise; see docs/cells.md.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"

namespace robocal {

struct TrackerSpec {
  /// The tracker's beam origin, base frame.
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  /// Distances at which it measures (its datasheet's window).
  double min_distance_mm = 0.0;
  double max_distance_mm = std::numeric_limits<double>::infinity();
};

/// A reflector (SMR in a nest, or a probe) on the tool: position and facing direction in the FLANGE frame.
struct ReflectorSpec {
  std::string id;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  /// Unit vector: the direction the reflector faces.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  /// The beam must arrive within this angle of the normal (a 1.5" red-ring SMR: about 30 degrees).
  double acceptance_half_angle_rad = 0.5235987755982988;
};

/// An axis-aligned box, base frame.
struct BoxObstacle {
  std::string id;
  Eigen::Vector3d min_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_mm = Eigen::Vector3d::Zero();
};

struct CellSpec {
  TrackerSpec tracker;
  /// Empty: one reflector "tool" at the model's tool point, facing along the tool z axis.
  std::vector<ReflectorSpec> reflectors;
  std::vector<BoxObstacle> obstacles;
  /// One radius per link capsule (num_joints): capsule i runs from the origin of joint frame i (frame 0: the
  /// base) to the origin of frame i + 1 (the last: the flange). Empty: DefaultLinkRadii(model).
  std::vector<double> link_radii_mm;
  /// The tool capsules (flange -> each reflector); <= 0: the last link's radius.
  double tool_radius_mm = 0.0;
  /// Capsules must keep this distance from obstacles and from non-adjacent capsules.
  double clearance_mm = 0.0;
  /// Joint ranges for planning (core units: rad / mm); empty: the model's limits. Must lie within them.
  Eigen::VectorXd joint_min;
  Eigen::VectorXd joint_max;
};

/// A documented default per preset (docs/cells.md), and for other robots a radius from the link lengths.
std::vector<double> DefaultLinkRadii(const RobotModel& model);

/// What a cell can reject a configuration for (the FAILED_PRECONDITION of an infeasible cell names the rule that
/// rejects most sampled configurations).
enum class CellRule {
  kJointRange,
  kObstacle,       ///< a capsule within clearance_mm of an obstacle
  kSelfCollision,  ///< two non-adjacent capsules within clearance_mm
  kDistance,       ///< no reflector within the tracker's distance window
  kIncidence,      ///< no reflector facing the tracker within its acceptance angle
  kBeam,           ///< no reflector with an unblocked beam
};
const char* ToString(CellRule rule);

struct ReflectorCheck {
  std::string id;
  bool measurable = false;
  /// Angle between the reflector's normal and the direction to the tracker (rad).
  double incidence_rad = 0.0;
  double distance_mm = 0.0;
  /// What blocks the beam ("link 3", "tool", an obstacle's id); empty if nothing.
  std::string blocked_by;
};

struct ConfigurationCheck {
  bool feasible = false;
  std::vector<ReflectorCheck> reflectors;
  /// The smallest surface distance between a capsule and an obstacle or a non-adjacent capsule (negative:
  /// penetration), and the pair that sets it (e.g. "link 2 / floor", "link 1 / link 4").
  double min_clearance_mm = std::numeric_limits<double>::infinity();
  std::string clearance_pair;
  /// The rules it fails (empty when feasible), each once, and a sentence per failure.
  std::vector<CellRule> failed_rules;
  std::vector<std::string> reasons;
};

/// A validated cell for one model. Build checks sizes and values (throws InvalidModelError naming fields such
/// as "reflectors[0].normal", "joint_ranges[2]", "link_radii_mm").
class Cell {
 public:
  static Cell Build(const RobotModel& model, CellSpec spec);
  const CellSpec& spec() const { return spec_; }
  /// The model's joint limits narrowed to the cell's joint ranges (for planners' sampling).
  RobotModel PlanningModel(const RobotModel& model) const;

 private:
  explicit Cell(CellSpec spec) : spec_(std::move(spec)) {}
  CellSpec spec_;
};

/// Full report of one configuration (core joint units).
ConfigurationCheck CheckConfiguration(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q);
/// The same decision without the report, as fast as possible (planners call it per candidate).
bool IsFeasible(const RobotModel& model, const Cell& cell, const Eigen::VectorXd& q);

/// How much of the joint ranges a cell leaves feasible: `samples` uniform configurations within the ranges
/// (seeded), how many are feasible, and per rule how many it rejects.
struct FeasibilityCensus {
  int samples = 0;
  int feasible = 0;
  std::vector<std::pair<CellRule, int>> rejected_by;  // every rule, in enum order
  /// The rule rejecting most, and its share of the samples.
  CellRule dominant = CellRule::kJointRange;
  double dominant_share = 0.0;
};
FeasibilityCensus SampleFeasibility(const RobotModel& model, const Cell& cell, int samples, std::uint64_t seed);

}  // namespace robocal

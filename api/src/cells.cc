// Cells on the wire.
#include "robocal/api/cells.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "robocal/api/json_reader.h"
#include "robocal/api/robots.h"

namespace robocal::api {
namespace {

Eigen::Vector3d Vec(const std::array<double, 3>& a) { return Eigen::Vector3d(a[0], a[1], a[2]); }
std::array<double, 3> Arr(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

void CheckUniqueIds(const std::vector<std::string>& ids, const char* list, Problems* problems) {
  std::set<std::string> seen;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (!seen.insert(ids[i]).second) {
      problems->Add(JoinPath(IndexPath(list, i), "id"), "\"" + ids[i] + "\" is used twice");
    }
  }
}

}  // namespace

CellWire ParseCellRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits) {
  Problems problems;
  CellWire cell;
  ObjectReader r(body, "", &problems);
  ReadRequest(r, &cell);
  const std::size_t joints = static_cast<std::size_t>(model.num_joints());
  if (cell.obstacles.size() > limits.max_array_length) {
    problems.Add("obstacles", "too many elements: " + std::to_string(cell.obstacles.size()) + " (limit " +
                                  std::to_string(limits.max_array_length) + ")");
  }
  if (r.Has("link_radii_mm") && cell.link_radii_mm.size() != joints) {
    problems.Add("link_radii_mm",
                 "expected " + std::to_string(joints) + " values, got " + std::to_string(cell.link_radii_mm.size()));
  }
  if (r.Has("joint_ranges") && cell.joint_ranges.size() != joints) {
    problems.Add("joint_ranges", "expected " + std::to_string(joints) + " ranges (one per joint), got " +
                                     std::to_string(cell.joint_ranges.size()));
  }
  r.RejectUnknown(WireFieldNames<CellWire>());
  std::vector<std::string> ids;
  for (const ReflectorWire& w : cell.reflectors) ids.push_back(w.id);
  CheckUniqueIds(ids, "reflectors", &problems);
  ids.clear();
  for (const ObstacleWire& w : cell.obstacles) ids.push_back(w.id);
  CheckUniqueIds(ids, "obstacles", &problems);
  problems.ThrowIfAny("invalid cell");
  (void)ToCell(cell, model);
  return cell;
}

Cell ToCell(const CellWire& w, const RobotModel& model) {
  CellSpec spec;
  spec.tracker.position_mm = Vec(w.tracker.position_mm);
  spec.tracker.min_distance_mm = w.tracker.min_distance_mm;
  if (w.tracker.max_distance_mm) spec.tracker.max_distance_mm = *w.tracker.max_distance_mm;
  for (const ReflectorWire& r : w.reflectors) {
    spec.reflectors.push_back({.id = r.id,
                               .position_mm = Vec(r.position_mm),
                               .normal = Vec(r.normal),
                               .acceptance_half_angle_rad = r.acceptance_half_angle_deg * kRadPerDeg});
  }
  for (const ObstacleWire& o : w.obstacles) {
    spec.obstacles.push_back({.id = o.id, .min_mm = Vec(o.box.min_mm), .max_mm = Vec(o.box.max_mm)});
  }
  spec.link_radii_mm = w.link_radii_mm;
  spec.tool_radius_mm = w.tool_radius_mm.value_or(0.0);
  spec.clearance_mm = w.clearance_mm;
  if (!w.joint_ranges.empty()) {
    std::vector<double> lo, hi;
    for (const JointRangeWire& range : w.joint_ranges) {
      lo.push_back(range.min);
      hi.push_back(range.max);
    }
    spec.joint_min = JointsToCore(model, lo);
    spec.joint_max = JointsToCore(model, hi);
  }
  try {
    return Cell::Build(model, std::move(spec));
  } catch (const InvalidModelError& e) {
    std::vector<FieldViolation> details;
    std::string message = "invalid cell";
    for (const FieldError& f : e.errors()) {
      details.push_back({f.field, f.reason});
      message += "; " + f.field + ": " + f.reason;
    }
    throw ApiError(Status::kInvalidArgument, message, details);
  }
}

namespace {

std::vector<ReflectorWire> ReflectorsOf(const CellSpec& spec) {
  std::vector<ReflectorWire> out;
  for (const ReflectorSpec& r : spec.reflectors) {
    out.push_back({.id = r.id,
                   .position_mm = Arr(r.position_mm),
                   .normal = Arr(r.normal),
                   .acceptance_half_angle_deg = r.acceptance_half_angle_rad * kDegPerRad});
  }
  return out;
}

// The spec's joint ranges in wire units; the robot's limits where the spec narrows none.
std::vector<JointRangeWire> JointRangesOf(const CellSpec& spec, const RobotModel& model) {
  const bool narrowed = spec.joint_min.size() == model.num_joints();
  const std::vector<double> lo = JointsToWire(model, narrowed ? spec.joint_min : model.lower_limits());
  const std::vector<double> hi = JointsToWire(model, narrowed ? spec.joint_max : model.upper_limits());
  std::vector<JointRangeWire> out;
  for (int i = 0; i < model.num_joints(); ++i) out.push_back({lo[i], hi[i]});
  return out;
}

}  // namespace

CellWire CellResource(const CellWire& request, const Cell& cell, const RobotModel& model) {
  const CellSpec& spec = cell.spec();
  CellWire w = request;
  if (w.reflectors.empty()) {
    // The default: one reflector at the tool point, facing along the tool z axis. (Given reflectors stay as
    // sent: a trip through radians would change their last digits.)
    const Transform& tool = model.spec().T_flange_tool;
    w.reflectors.push_back({"tool", Arr(tool.translation()), Arr(tool.linear().col(2)), 30.0});
  }
  w.link_radii_mm = spec.link_radii_mm.empty() ? DefaultLinkRadii(model) : spec.link_radii_mm;
  w.tool_radius_mm = spec.tool_radius_mm > 0.0 ? spec.tool_radius_mm : w.link_radii_mm.back();
  w.joint_ranges = JointRangesOf(spec, model);
  return w;
}

CellWire CellRequestOf(const std::string& id, const std::string& robot, const CellSpec& spec,
                       const RobotModel& model) {
  CellWire w;
  w.id = id;
  w.robot = robot;
  w.tracker.position_mm = Arr(spec.tracker.position_mm);
  w.tracker.min_distance_mm = spec.tracker.min_distance_mm;
  if (std::isfinite(spec.tracker.max_distance_mm)) w.tracker.max_distance_mm = spec.tracker.max_distance_mm;
  w.reflectors = ReflectorsOf(spec);
  for (const BoxObstacle& box : spec.obstacles) {
    w.obstacles.push_back({.id = box.id, .box = {.min_mm = Arr(box.min_mm), .max_mm = Arr(box.max_mm)}});
  }
  w.link_radii_mm = spec.link_radii_mm.empty() ? DefaultLinkRadii(model) : spec.link_radii_mm;
  if (spec.tool_radius_mm > 0.0) w.tool_radius_mm = spec.tool_radius_mm;
  w.clearance_mm = spec.clearance_mm;
  w.joint_ranges = JointRangesOf(spec, model);
  return w;
}

// ---------------------------------------------------------------------------------------------- json

// ---------------------------------------------------------------------------------------------- checks

ConfigurationCheckWire ToWire(const ConfigurationCheck& c) {
  ConfigurationCheckWire w;
  w.feasible = c.feasible;
  for (const ReflectorCheck& r : c.reflectors) {
    ReflectorCheckWire rw{r.id, r.measurable, r.incidence_rad * kDegPerRad, r.distance_mm, std::nullopt};
    if (!r.blocked_by.empty()) rw.blocked_by = r.blocked_by;
    w.reflectors.push_back(std::move(rw));
  }
  w.min_clearance_mm = c.min_clearance_mm;
  w.clearance_pair = c.clearance_pair;
  w.failed_rules = c.failed_rules;
  w.reasons = c.reasons;
  return w;
}

ForwardRequest ParseCellCheckRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits) {
  return ParseJointsRequest(body, model, std::min(kMaxCheckConfigurations, limits.max_array_length),
                            "invalid check request");
}

// The shapes' to_json / from_json, instantiated here once (ROBOCAL_WIRE_DECLARE).
ROBOCAL_WIRE_DEFINE(TrackerWire);
ROBOCAL_WIRE_DEFINE(ReflectorWire);
ROBOCAL_WIRE_DEFINE(BoxWire);
ROBOCAL_WIRE_DEFINE(ObstacleWire);
ROBOCAL_WIRE_DEFINE(CellWire);
ROBOCAL_WIRE_DEFINE(CellList);
ROBOCAL_WIRE_DEFINE(ReflectorCheckWire);
ROBOCAL_WIRE_DEFINE(ConfigurationCheckWire);
ROBOCAL_WIRE_DEFINE(CellCheckResult);

}  // namespace robocal::api

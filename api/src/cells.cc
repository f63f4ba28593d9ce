// Cells on the wire.
#include "robocal/api/cells.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "robocal/api/json_reader.h"
#include "robocal/api/robots.h"

namespace robocal::api {
namespace {

// Beyond this a count is a typing mistake, not a cell: more reflectors than any tool carries (lengths:
// kMaxLengthMm).
constexpr std::size_t kMaxReflectors = 16;
// A cell's boxes: floor, tables, fixtures, fences. The bound keeps one configuration's check (every capsule and
// beam against every box) within tens of microseconds, so a :check of max_array_length configurations stays
// well under a second.
constexpr std::size_t kMaxObstacles = 128;

// Records a problem for each coordinate of `v` beyond the plausible length.
void CheckLengths(const std::array<double, 3>& v, const std::string& path, Problems* problems) {
  for (std::size_t i = 0; i < 3; ++i) {
    if (std::abs(v[i]) > kMaxLengthMm) problems->Add(IndexPath(path, i), "implausibly large (limit 1e9 mm)");
  }
}

Eigen::Vector3d Vec(const std::array<double, 3>& a) { return Eigen::Vector3d(a[0], a[1], a[2]); }
std::array<double, 3> Arr(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// Reads a named list of objects at `key` with `read` for each element.
template <typename T, typename Read>
void ReadList(ObjectReader& r, const char* key, std::size_t max_size, Problems* problems, std::vector<T>* out,
              Read read) {
  if (const nlohmann::json* a = r.Array(key, false, 0, max_size)) {
    out->resize(a->size());
    for (std::size_t i = 0; i < a->size(); ++i) {
      ObjectReader item((*a)[i], IndexPath(key, i), problems);
      read(item, &(*out)[i]);
    }
  }
}

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
  if (r.String("id", true, &cell.id) && !IsValidId(cell.id)) problems.Add("id", kIdRule);
  r.String("description", false, &cell.description, 1024);
  r.String("robot", true, &cell.robot, 64);
  if (const nlohmann::json* t = r.Get("tracker")) {
    ObjectReader tr(*t, "tracker", &problems);
    if (tr.FixedNumbers("position_mm", true, cell.tracker.position_mm.data(), 3)) {
      CheckLengths(cell.tracker.position_mm, "tracker.position_mm", &problems);
    }
    tr.Number("min_distance_mm", false, &cell.tracker.min_distance_mm, 0.0, kMaxLengthMm);
    double max = 0.0;
    if (tr.Number("max_distance_mm", false, &max, 0.0, kMaxLengthMm)) cell.tracker.max_distance_mm = max;
    tr.RejectUnknown(WireFieldNames<TrackerWire>());
  } else if (r.ok()) {
    problems.Add("tracker", "required");
  }
  ReadList(r, "reflectors", kMaxReflectors, &problems, &cell.reflectors,
           [&problems](ObjectReader& item, ReflectorWire* w) {
    // Ids as the service's own (no commas, quotes or spaces: they appear in CSV columns and in blocked_by).
    if (item.String("id", true, &w->id, 64) && !IsValidId(w->id)) problems.Add(JoinPath(item.path(), "id"), kIdRule);
    if (item.FixedNumbers("position_mm", true, w->position_mm.data(), 3)) {
      CheckLengths(w->position_mm, JoinPath(item.path(), "position_mm"), &problems);
    }
    item.FixedNumbers("normal", true, w->normal.data(), 3);
    // The core refuses 0 with its reason; (0, 180] as the core and docs/cells.md say.
    item.Number("acceptance_half_angle_deg", false, &w->acceptance_half_angle_deg, 0.0, 180.0);
    item.RejectUnknown(WireFieldNames<ReflectorWire>());
  });
  ReadList(r, "obstacles", std::min(kMaxObstacles, limits.max_array_length), &problems, &cell.obstacles,
           [&problems](ObjectReader& item, ObstacleWire* w) {
             if (item.String("id", true, &w->id, 64) && !IsValidId(w->id)) {
               problems.Add(JoinPath(item.path(), "id"), kIdRule);
             }
             if (const nlohmann::json* b = item.Get("box")) {
               ObjectReader box(*b, JoinPath(item.path(), "box"), &problems);
               if (box.FixedNumbers("min_mm", true, w->box.min_mm.data(), 3)) {
                 CheckLengths(w->box.min_mm, JoinPath(box.path(), "min_mm"), &problems);
               }
               if (box.FixedNumbers("max_mm", true, w->box.max_mm.data(), 3)) {
                 CheckLengths(w->box.max_mm, JoinPath(box.path(), "max_mm"), &problems);
               }
               box.RejectUnknown(WireFieldNames<BoxWire>());
             } else if (item.ok()) {
               problems.Add(JoinPath(item.path(), "box"), "required");
             }
             item.RejectUnknown(WireFieldNames<ObstacleWire>());
           });
  const std::size_t joints = static_cast<std::size_t>(model.num_joints());
  if (r.Numbers("link_radii_mm", false, &cell.link_radii_mm, joints, joints)) {
    for (std::size_t i = 0; i < cell.link_radii_mm.size(); ++i) {
      if (cell.link_radii_mm[i] < 0.0 || cell.link_radii_mm[i] > kMaxLengthMm) {
        problems.Add(IndexPath("link_radii_mm", i), "must be in [0, 1e9] mm");
      }
    }
  }
  double tool_radius = 0.0;
  if (r.Number("tool_radius_mm", false, &tool_radius, 0.0, kMaxLengthMm)) {
    // Absent means the last link's radius; a given radius must be one.
    if (tool_radius > 0.0) {
      cell.tool_radius_mm = tool_radius;
    } else {
      problems.Add("tool_radius_mm", "must be > 0 mm (leave it out for the last link's radius)");
    }
  }
  r.Number("clearance_mm", false, &cell.clearance_mm, 0.0, kMaxLengthMm);
  if (const nlohmann::json* a = r.Array("joint_ranges", false, joints, joints)) {
    cell.joint_ranges.resize(a->size());
    for (std::size_t i = 0; i < a->size(); ++i) {
      ObjectReader range((*a)[i], IndexPath("joint_ranges", i), &problems);
      range.Number("min", true, &cell.joint_ranges[i].min);
      range.Number("max", true, &cell.joint_ranges[i].max);
      range.RejectUnknown(WireFieldNames<JointRangeWire>());
    }
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
    spec.reflectors.push_back({r.id, Vec(r.position_mm), Vec(r.normal), r.acceptance_half_angle_deg * kRadPerDeg});
  }
  for (const ObstacleWire& o : w.obstacles) spec.obstacles.push_back({o.id, Vec(o.box.min_mm), Vec(o.box.max_mm)});
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
    out.push_back({r.id, Arr(r.position_mm), Arr(r.normal), r.acceptance_half_angle_rad * kDegPerRad});
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

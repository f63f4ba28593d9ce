// Wire shapes of cells: the tracker, reflectors, obstacles and capsules of a measurement cell (the request and
// the resource), their mapping to the core's CellSpec, and the feasibility report of configurations.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/robots.h"
#include "robocal/api/wire.h"
#include "robocal/core/cell.h"
#include "robocal/core/robot_model.h"

namespace robocal::api {

struct TrackerWire {
  std::array<double, 3> position_mm{0.0, 0.0, 0.0};
  double min_distance_mm = 0.0;
  /// Unset: no upper bound.
  std::optional<double> max_distance_mm;
};

/// Position and facing direction (unit vector) in the flange frame.
struct ReflectorWire {
  std::string id;
  std::array<double, 3> position_mm{0.0, 0.0, 0.0};
  std::array<double, 3> normal{0.0, 0.0, 1.0};
  double acceptance_half_angle_deg = 30.0;
};

/// An axis-aligned box in the robot's base frame: its corners of least and greatest coordinates (mm).
struct BoxWire {
  std::array<double, 3> min_mm{0.0, 0.0, 0.0};
  std::array<double, 3> max_mm{0.0, 0.0, 0.0};
};
/// An obstacle of the cell: {"id", "box"}.
struct ObstacleWire {
  std::string id;
  BoxWire box;
};

/// A cell's boxes: floor, tables, fixtures, fences. The bound keeps one configuration's check (every capsule and
/// beam against every box) within tens of microseconds, so a :check of max_array_length configurations stays
/// well under a second.
inline constexpr std::size_t kMaxCellObstacles = 128;

template <>
struct WireFields<TrackerWire> {
  using S = TrackerWire;
  static constexpr auto fields =
      std::make_tuple(Field{"position_mm", &S::position_mm}.Mandatory().Range(-kMaxLengthMm, kMaxLengthMm),
                      Field{"min_distance_mm", &S::min_distance_mm}.Range(0.0, kMaxLengthMm),
                      Field{"max_distance_mm", &S::max_distance_mm, Presence::kOmitEmpty}.Range(0.0, kMaxLengthMm));
};
ROBOCAL_WIRE_DECLARE(TrackerWire);
template <>
struct WireFields<ReflectorWire> {
  using S = ReflectorWire;
  static constexpr auto fields = std::make_tuple(
      // Ids as the service's own (no commas, quotes or spaces: they appear in CSV columns and in blocked_by).
      Field{"id", &S::id}.Mandatory().Size(0, 64).Rule(&IsValidId, kIdRule),
      Field{"position_mm", &S::position_mm}.Mandatory().Range(-kMaxLengthMm, kMaxLengthMm),
      Field{"normal", &S::normal}.Mandatory(),
      // The core refuses 0 with its reason; (0, 180] as the core and docs/cells.md say.
      Field{"acceptance_half_angle_deg", &S::acceptance_half_angle_deg}.Range(0.0, 180.0));
};
ROBOCAL_WIRE_DECLARE(ReflectorWire);
template <>
struct WireFields<BoxWire> {
  using S = BoxWire;
  static constexpr auto fields =
      std::make_tuple(Field{"min_mm", &S::min_mm}.Mandatory().Range(-kMaxLengthMm, kMaxLengthMm),
                      Field{"max_mm", &S::max_mm}.Mandatory().Range(-kMaxLengthMm, kMaxLengthMm));
};
ROBOCAL_WIRE_DECLARE(BoxWire);
template <>
struct WireFields<ObstacleWire> {
  using S = ObstacleWire;
  static constexpr auto fields = std::make_tuple(Field{"id", &S::id}.Mandatory().Size(0, 64).Rule(&IsValidId, kIdRule),
                                                 Field{"box", &S::box}.Mandatory());
};
ROBOCAL_WIRE_DECLARE(ObstacleWire);

/// POST /v1/cells, and the cell resource (which has every default filled in: reflectors, link radii, tool
/// radius, joint ranges).
struct CellWire {
  std::string id;
  std::string description;
  std::string robot;
  TrackerWire tracker;
  std::vector<ReflectorWire> reflectors;
  std::vector<ObstacleWire> obstacles;
  std::vector<double> link_radii_mm;
  std::optional<double> tool_radius_mm;
  double clearance_mm = 0.0;
  std::vector<JointRangeWire> joint_ranges;
};
/// Validates a request body's fields (types, finiteness, sizes against `model`); the geometry is then checked by
/// ToCell.
CellWire ParseCellRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits);
template <>
struct WireFields<CellWire> {
  using S = CellWire;
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id}.Mandatory().Rule(&IsValidId, kIdRule), Field{"description", &S::description}.Size(0, 1024),
      Field{"robot", &S::robot}.Mandatory().Size(0, 64), Field{"tracker", &S::tracker}.Mandatory(),
      Field{"reflectors", &S::reflectors}.Size(0, kMaxReflectors),
      Field{"obstacles", &S::obstacles}.Size(0, kMaxCellObstacles),
      // One per joint (the parser checks the count against the robot).
      Field{"link_radii_mm", &S::link_radii_mm, Presence::kSetByServer}.Range(0.0, kMaxLengthMm),
      // Absent: the last link's radius; a given radius must be one.
      Field{"tool_radius_mm", &S::tool_radius_mm, Presence::kSetByServer}
          .Range(0.0, kMaxLengthMm)
          .Rule(
              +[](const std::optional<double>& r) { return *r > 0.0; },
              "must be > 0 mm (leave it out for the last link's radius)"),
      Field{"clearance_mm", &S::clearance_mm}.Range(0.0, kMaxLengthMm),
      Field{"joint_ranges", &S::joint_ranges, Presence::kSetByServer});
};
ROBOCAL_WIRE_DECLARE(CellWire);
/// The core cell (throws ApiError kInvalidArgument naming the fields the core rejects).
Cell ToCell(const CellWire& cell, const RobotModel& model);
/// The resource of a validated cell: every default the core filled in written out.
CellWire CellResource(const CellWire& request, const Cell& cell, const RobotModel& model);
/// The request that creates the cell of a core spec (the inverse of ToCell for what a spec sets): tracker,
/// obstacles, clearance, joint ranges and link radii written out (defaults included); reflectors and the tool
/// radius left to the server's defaults where the spec leaves them so. No description.
CellWire CellRequestOf(const std::string& id, const std::string& robot, const CellSpec& spec,
                       const RobotModel& model);

/// GET /v1/cells: cells in id order; next_page_token when there are more.
struct CellList {
  std::vector<CellWire> cells;
  std::optional<std::string> next_page_token;
};
template <>
struct WireFields<CellList> {
  using S = CellList;
  static constexpr auto fields = std::make_tuple(
      Field{"cells", &S::cells},
      Field{"next_page_token", &S::next_page_token, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(CellList);

/// One reflector of a configuration's report.
struct ReflectorCheckWire {
  std::string id;
  bool measurable = false;
  double incidence_deg = 0.0;
  double distance_mm = 0.0;
  /// What blocks the beam ("link 3", "tool smr1", an obstacle's id); absent if nothing does.
  std::optional<std::string> blocked_by;
};

template <>
struct WireFields<ReflectorCheckWire> {
  using S = ReflectorCheckWire;
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id},
      Field{"measurable", &S::measurable},
      Field{"incidence_deg", &S::incidence_deg},
      Field{"distance_mm", &S::distance_mm},
      Field{"blocked_by", &S::blocked_by, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(ReflectorCheckWire);

/// The feasibility report of one configuration.
struct ConfigurationCheckWire {
  bool feasible = false;
  std::vector<ReflectorCheckWire> reflectors;
  /// Null when the cell has nothing to collide with.
  double min_clearance_mm = 0.0;
  std::string clearance_pair;
  std::vector<CellRule> failed_rules;
  std::vector<std::string> reasons;
};
template <>
struct WireFields<ConfigurationCheckWire> {
  using S = ConfigurationCheckWire;
  static constexpr auto fields = std::make_tuple(
      Field{"feasible", &S::feasible},
      Field{"reflectors", &S::reflectors},
      Field{"min_clearance_mm", &S::min_clearance_mm},
      Field{"clearance_pair", &S::clearance_pair},
      Field{"failed_rules", &S::failed_rules},
      Field{"reasons", &S::reasons});
};
ROBOCAL_WIRE_DECLARE(ConfigurationCheckWire);
ConfigurationCheckWire ToWire(const ConfigurationCheck& check);

/// Configurations one :check takes: in the largest cell (16 reflectors, 128 obstacles) a check of 1000 takes
/// 0.14 to 0.27 s and its reply 3.4 MB (docs/cells.md).
inline constexpr std::size_t kMaxCheckConfigurations = 1000;
/// The body of POST /v1/cells/{cell}:check, {"joints": [[...]]}: 1 to min(kMaxCheckConfigurations,
/// max_array_length) vectors within the robot's limits (a ForwardRequest).
ForwardRequest ParseCellCheckRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits);

/// The reply of POST /v1/cells/{cell}:check.
struct CellCheckResult {
  std::string cell;
  std::vector<ConfigurationCheckWire> results;
};
template <>
struct WireFields<CellCheckResult> {
  using S = CellCheckResult;
  static constexpr auto fields = std::make_tuple(
      Field{"cell", &S::cell},
      Field{"results", &S::results});
};
ROBOCAL_WIRE_DECLARE(CellCheckResult);

}  // namespace robocal::api

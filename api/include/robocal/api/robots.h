// Wire shapes of the robot resources: registering a robot, the robot resource and its list, forward kinematics
// (of a robot or of a calibrated campaign), and joint vectors between wire units (deg / mm) and the core's.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "robocal/api/wire.h"
#include "robocal/core/robot_model.h"

namespace robocal::api {

/// A joint's error map (JointMap) in wire units: knots every knot_spacing_deg from first_knot_deg, and the cubic
/// B-spline's coefficients in degrees (intervals + 3 of them); beyond its knots the map holds its end value.
struct JointMapWire {
  double first_knot_deg = 0.0;
  double knot_spacing_deg = 0.0;
  std::vector<double> coefficients_deg;
};
/// Angles beyond this are typing mistakes, not geometry: a million degrees (lengths: kMaxLengthMm).
inline constexpr double kMaxAngleDeg = 1e6;
/// A link heavier than 100 t is a unit mistake.
inline constexpr double kMaxMassKg = 1e5;
/// Joint terms a robot may hold: the core's bounds of a plausible joint (robot_model.h) in wire units; beyond is
/// no robot joint's compliance, harmonic, gear's or encoder's error.
inline constexpr double kMaxComplianceDegPerNm = kImplausibleComplianceRadPerNm * kDegPerRad;
inline constexpr double kMaxHarmonicDeg = kImplausibleHarmonicRad * kDegPerRad;

template <>
struct WireFields<JointMapWire> {
  using S = JointMapWire;
  static constexpr auto fields =
      std::make_tuple(Field{"first_knot_deg", &S::first_knot_deg}.Mandatory().Range(-kMaxAngleDeg, kMaxAngleDeg),
                      Field{"knot_spacing_deg", &S::knot_spacing_deg}.Mandatory().Range(
                          kMinMapKnotSpacingRad* kDegPerRad, kMaxMapKnotSpacingRad* kDegPerRad),
                      Field{"coefficients_deg", &S::coefficients_deg}
                          .Mandatory()
                          .Size(4, kMaxMapIntervals + 3)
                          .Range(-kMaxHarmonicDeg, kMaxHarmonicDeg));
};
ROBOCAL_WIRE_DECLARE(JointMapWire);

/// One joint of a robot definition. Angles in degrees, lengths in mm. Limits are in the joint's unit:
/// "min_deg"/"max_deg" for a revolute joint, "min_mm"/"max_mm" for a prismatic one. The geometry is the
/// convention's: a dh / mdh row (mdh: alpha and a of the previous link, as in Craig's table), or for
/// "transform" the fixed transform from the previous joint frame (xyz_mm, rpy_deg).
struct JointWire {
  std::string name;
  JointType type = JointType::kRevolute;
  double a_mm = 0.0, alpha_deg = 0.0, d_mm = 0.0, theta_deg = 0.0;
  std::array<double, 3> xyz_mm{0.0, 0.0, 0.0};
  std::array<double, 3> rpy_deg{0.0, 0.0, 0.0};
  double min = 0.0, max = 0.0;
  /// The link this joint moves: mass (kg; 0: unknown) and centre of mass (mm, link frame: JointSpec::com_mm).
  double mass_kg = 0.0;
  std::array<double, 3> com_mm{0.0, 0.0, 0.0};
  /// Joint terms the robot holds (JointSpec::compliance_rad_per_nm, harmonics_rad), in wire units: the compliance
  /// in degrees per N*m, the harmonic amplitudes in degrees of sin q, cos q, sin 2q, cos 2q (0: none). A robot
  /// registered from a calibration with joint terms holds them.
  double compliance_deg_per_nm = 0.0;
  std::array<double, 4> harmonics_deg{0.0, 0.0, 0.0, 0.0};
  /// The joint's error map (JointSpec::error_map); unset: none.
  std::optional<JointMapWire> error_map;
  /// The convention of the robot the joint belongs to, which picks its geometry keys. Not a key of the joint:
  /// the robot's "convention" gives it (a robot's joints are written and read with the robot's; JointToWire
  /// sets it, so that a joint written on its own has its robot's keys too).
  GeometryConvention convention = GeometryConvention::kStandardDh;
};
/// The keys a joint has in every robot shape: type, the geometry of its robot's convention, the limits in its
/// unit (min_deg / max_deg revolute, min_mm / max_mm prismatic).
struct JointGeometryFields {
  using S = JointWire;
  static constexpr bool (*kTransform)(const S&) = +[](const S& j) {
    return j.convention == GeometryConvention::kTransform;
  };
  static constexpr bool (*kDh)(const S&) = +[](const S& j) { return j.convention != GeometryConvention::kTransform; };
  static constexpr bool (*kRevolute)(const S&) = +[](const S& j) { return j.type == JointType::kRevolute; };
  static constexpr bool (*kPrismatic)(const S&) = +[](const S& j) { return j.type == JointType::kPrismatic; };
  using C = JointSpec;
  static constexpr CoreUnit kDeg = CoreUnit::kDegForRad;
  static constexpr auto fields = std::make_tuple(
      Field{"type", &S::type}.Mandatory().Core(&C::type), Field{"xyz_mm", &S::xyz_mm}.When(kTransform).Core(&C::xyz_mm),
      Field{"rpy_deg", &S::rpy_deg}.When(kTransform).Core(&C::rpy_rad, kDeg),
      Field{"a_mm", &S::a_mm}.When(kDh).Range(-kMaxLengthMm, kMaxLengthMm).Core(&C::a_mm),
      Field{"alpha_deg", &S::alpha_deg}.When(kDh).Range(-360.0, 360.0).Core(&C::alpha_rad, kDeg),
      Field{"d_mm", &S::d_mm}.When(kDh).Range(-kMaxLengthMm, kMaxLengthMm).Core(&C::d_mm),
      Field{"theta_deg", &S::theta_deg}.When(kDh).Range(-360.0, 360.0).Core(&C::theta_rad, kDeg),
      Field{"min_deg", &S::min}.When(kRevolute).Mandatory().Range(-kMaxAngleDeg, kMaxAngleDeg),
      Field{"max_deg", &S::max}.When(kRevolute).Mandatory().Range(-kMaxAngleDeg, kMaxAngleDeg),
      Field{"min_mm", &S::min}.When(kPrismatic).Mandatory().Range(-kMaxLengthMm, kMaxLengthMm),
      Field{"max_mm", &S::max}.When(kPrismatic).Mandatory().Range(-kMaxLengthMm, kMaxLengthMm));
};
/// A joint of a definition: the name may be left out (the core names the joint), the mass properties and joint
/// terms are given when there are any (com_mm with a mass). The robot resource's joint (RobotJoint) states every
/// one of them (ResourceRows).
template <>
struct WireFields<JointWire> {
  using S = JointWire;
  using C = JointSpec;
  static constexpr Presence kOmit = Presence::kOmitEmpty;
  static constexpr CoreUnit kDeg = CoreUnit::kDegForRad;
  static constexpr auto fields =
      std::tuple_cat(std::make_tuple(Field{"name", &S::name, kOmit}.Size(0, 64)), JointGeometryFields::fields,
                     std::make_tuple(Field{"mass_kg", &S::mass_kg, kOmit}.Range(0.0, kMaxMassKg).Core(&C::mass_kg),
                                     Field{"com_mm", &S::com_mm, Presence::kOptionalOnRead}
                                         .When(+[](const S& j) { return j.mass_kg > 0.0; })
                                         .EveryFormInResource()
                                         .Core(&C::com_mm),
                                     Field{"compliance_deg_per_nm", &S::compliance_deg_per_nm, kOmit}
                                         .Range(-kMaxComplianceDegPerNm, kMaxComplianceDegPerNm)
                                         .Core(&C::compliance_rad_per_nm, kDeg),
                                     Field{"harmonics_deg", &S::harmonics_deg, kOmit}
                                         .Range(-kMaxHarmonicDeg, kMaxHarmonicDeg)
                                         .Core(&C::harmonics_rad, kDeg),
                                     Field{"error_map", &S::error_map, kOmit}.InResource(kOmit)));
};
ROBOCAL_WIRE_DECLARE(JointWire);

/// The chain of a robot imported from a URDF: its base and tip links.
struct UrdfChainWire {
  std::string base_link;
  std::string tip_link;
};
template <>
struct WireFields<UrdfChainWire> {
  static constexpr auto fields =
      std::make_tuple(Field{"base_link", &UrdfChainWire::base_link}, Field{"tip_link", &UrdfChainWire::tip_link});
};
ROBOCAL_WIRE_DECLARE(UrdfChainWire);
/// Where an imported robot came from: the URDF document and the chain taken from it.
struct UrdfSource : UrdfChainWire {
  std::string xml;
};
template <>
struct WireFields<UrdfSource> {
  static constexpr auto fields =
      std::tuple_cat(std::make_tuple(Field{"xml", &UrdfSource::xml}), WireFields<UrdfChainWire>::fields);
};
ROBOCAL_WIRE_DECLARE(UrdfSource);

/// Where a robot registered from a campaign's calibration came from (POST /v1/robots with "from_calibration"):
/// the campaign, its robot and when the calibration was made.
struct CalibrationSource {
  std::string campaign;
  std::string robot;
  std::int64_t created_unix_ms = 0;
  /// Per joint, the range [min, max] its calibration measurements covered (deg / mm, the joint's unit): the
  /// calibration was identified there; joint harmonics especially hold only there (docs/robots.md). Empty in
  /// definitions stored before it was kept.
  std::vector<JointRangeWire> joint_ranges;
};
template <>
struct WireFields<CalibrationSource> {
  using S = CalibrationSource;
  static constexpr auto fields = std::make_tuple(Field{"campaign", &S::campaign}, Field{"robot", &S::robot},
                                                 Field{"created_unix_ms", &S::created_unix_ms},
                                                 Field{"joint_ranges", &S::joint_ranges, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(CalibrationSource);

/// POST /v1/robots, and the definition stored for a robot (and copied into each campaign). Either a full table
/// (convention + joints) or `from_preset` (a preset's geometry, with base / tool optionally replaced).
struct RegisterRobotRequest {
  std::string id;
  std::string description;
  std::string from_preset;
  GeometryConvention convention = GeometryConvention::kStandardDh;
  std::vector<JointWire> joints;
  std::optional<PoseWire> base;  // tracker (world) -> robot base
  std::optional<PoseWire> tool;  // flange -> tool (measured point, z = tool axis)
  /// Last joint frame (after its motion) -> flange: transform convention only (an imported URDF's fixed joints
  /// down to its tip link); DH tables derive it.
  std::optional<PoseWire> flange;
  /// A robot imported from a URDF: the document and the chain, kept for the calibrated URDF export.
  std::optional<UrdfSource> urdf;
  /// A robot registered from a calibration: its provenance (set by the service, never by a request).
  std::optional<CalibrationSource> calibrated_from;
  /// The direction of gravity in the base frame (any non-zero length; normalised): -z when not given.
  std::optional<std::array<double, 3>> gravity;
};
/// Validates a request body (every problem with its field; the geometry through the core).
RegisterRobotRequest ParseRegisterRobotRequest(const nlohmann::json& body, const Limits& limits);
namespace detail {
// A robot's "joints": each joint written and read with the robot's convention (JointWire::convention).
template <typename Robot>
bool WriteJoints(const Robot& robot, nlohmann::json* value) {
  *value = nlohmann::json::array();
  for (auto joint : robot.joints) {
    joint.convention = robot.convention;
    value->push_back(joint);
  }
  return true;
}
template <typename Robot>
void ReadJoints(const nlohmann::json* value, const std::string& path, Robot* robot) {
  if (value == nullptr) ThrowWire(path, "required");
  if (!value->is_array()) ThrowWire(path, "expected an array");
  robot->joints.assign(value->size(), {});
  for (std::size_t i = 0; i < value->size(); ++i) {
    robot->joints[i].convention = robot->convention;
    ReadWire((*value)[i], IndexPathOf(path, i), &robot->joints[i]);
  }
}
}  // namespace detail
/// The definition as a request body (joints in the convention's keys only); read structurally, without range
/// checks (stored definitions stay readable when request validation tightens).
template <>
struct WireFields<RegisterRobotRequest> {
  using S = RegisterRobotRequest;
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id}.Mandatory().Rule(&IsValidId, kIdRule),
      Field{"description", &S::description, Presence::kOmitEmpty}.Size(0, 1024),
      // One of the presets (a list the table cannot hold), and then no joints: the parser's.
      Field{"from_preset", &S::from_preset, Presence::kOmitEmpty}.Apart(),
      // A table, unless the definition is a preset's.
      Field{"convention", &S::convention}.When(+[](const S& r) { return r.from_preset.empty(); }).Apart(),
      Computed<S>{
          "joints",
          +[](const S& r, nlohmann::json* value) { return r.from_preset.empty() && detail::WriteJoints(r, value); },
          +[](const nlohmann::json* value, const std::string& path, S* r) {
            if (r->from_preset.empty()) detail::ReadJoints(value, path, r);
          }},
      Field{"base", &S::base, Presence::kOmitEmpty}, Field{"tool", &S::tool, Presence::kOmitEmpty},
      Field{"flange", &S::flange, Presence::kOmitEmpty},
      Field{"gravity", &S::gravity, Presence::kOmitEmpty}.Rule(
          +[](const std::optional<std::array<double, 3>>& g) {
            return (*g)[0] != 0.0 || (*g)[1] != 0.0 || (*g)[2] != 0.0;
          },
          "must be a non-zero vector (the direction of gravity in the base frame)"),
      Field{"urdf_source", &S::urdf, Presence::kServerOnly},
      Field{"calibrated_from", &S::calibrated_from, Presence::kServerOnly});
};
ROBOCAL_WIRE_DECLARE(RegisterRobotRequest);
/// POST /v1/robots with a URDF document instead of a table (docs/formats.md): the chain from base_link down
/// to tip_link becomes a transform-convention robot that keeps the URDF's joint names. `id` may be left out:
/// the URDF's robot name then gives it (lower case, other characters as '_').
struct ImportUrdfRequest {
  std::string id;
  std::string description;
  std::string urdf;
  std::string base_link;
  std::string tip_link;
  std::optional<PoseWire> base;  // tracker (world) -> base_link
  std::optional<PoseWire> tool;  // tip_link (the flange) -> tool
};
/// The largest URDF document accepted (bytes).
inline constexpr std::size_t kMaxUrdfBytes = 4u << 20;
/// True for a body that imports a URDF (it has a "urdf", "base_link" or "tip_link" member).
bool IsUrdfImport(const nlohmann::json& body);
/// Validates the request's fields (the document itself is read by the importer).
ImportUrdfRequest ParseImportUrdfRequest(const nlohmann::json& body, const Limits& limits);
template <>
struct WireFields<ImportUrdfRequest> {
  using S = ImportUrdfRequest;
  static constexpr auto fields =
      std::make_tuple(Field{"id", &S::id, Presence::kOmitEmpty}.Rule(&IsValidId, kIdRule),
                      Field{"description", &S::description, Presence::kOmitEmpty}.Size(0, 1024),
                      Field{"urdf", &S::urdf}.Mandatory().Size(0, kMaxUrdfBytes),
                      Field{"base_link", &S::base_link}.Mandatory(), Field{"tip_link", &S::tip_link}.Mandatory(),
                      Field{"base", &S::base, Presence::kOmitEmpty}, Field{"tool", &S::tool, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(ImportUrdfRequest);

/// POST /v1/robots {"id", "description"?, "from_calibration": CAMPAIGN}: the campaign's calibrated robot as a
/// robot of its own (docs/api.md, "A calibration in a new session"): the calibrated chain in the transform
/// convention, the joints' names and limits, the nominal base and the calibrated tool; the tracker -> base
/// registration stays with the campaign.
struct RobotFromCalibrationRequest {
  std::string id;
  std::string description;
  std::string campaign;
};
/// True for a body with a "from_calibration" member.
bool IsFromCalibration(const nlohmann::json& body);
RobotFromCalibrationRequest ParseRobotFromCalibrationRequest(const nlohmann::json& body);
template <>
struct WireFields<RobotFromCalibrationRequest> {
  using S = RobotFromCalibrationRequest;
  static constexpr auto fields =
      std::make_tuple(Field{"id", &S::id}.Mandatory().Rule(&IsValidId, kIdRule),
                      Field{"description", &S::description, Presence::kOmitEmpty}.Size(0, 1024),
                      Field{"from_calibration", &S::campaign}.Mandatory().Size(0, 64).Rule(
                          &IsValidId, "a campaign id: must match [a-z0-9][a-z0-9_.-]{0,63}"));
};
ROBOCAL_WIRE_DECLARE(RobotFromCalibrationRequest);

/// Why a joint's held terms are no robot joint's, in wire units (e.g. "harmonics_deg[0] 0.9 is beyond +-0.573
/// deg (0.01 rad)"), or empty: the bounds of RobotModel::Build (kImplausibleComplianceRadPerNm,
/// kImplausibleHarmonicRad).
std::string ImplausibleJointTerms(const JointWire& joint);

/// The core spec of a definition.
RobotModelSpec ToSpec(const RegisterRobotRequest& request);
/// A core joint in wire units (deg, mm), of a robot in `convention`.
JointWire JointToWire(const JointSpec& joint, GeometryConvention convention);
/// The definition that registers `spec`'s model under `id` (a table in the spec's convention, base and tool; no
/// preset, no URDF document): e.g. a calibrated DH table (GET /v1/campaigns/{c}/calibration?format=dh).
RegisterRobotRequest DefinitionOf(const std::string& id, const RobotModelSpec& spec, const std::string& description);
/// The model of a definition (throws ApiError kInvalidArgument naming the fields the core rejects).
RobotModel BuildModel(const RegisterRobotRequest& request);

/// One joint of the robot resource: the definition's fields (all geometry fields of the convention) plus its
/// unit ("deg" or "mm", the unit of its limits and of joint values on the wire).
struct RobotJoint : JointWire {
  std::string unit;
};
/// The resource states every joint's name and mass properties (0: unknown), a definition only those it has.
template <>
struct WireFields<RobotJoint> {
  static constexpr auto fields =
      std::tuple_cat(ResourceRows(WireFields<JointWire>::fields), std::make_tuple(Field{"unit", &RobotJoint::unit}));
};
ROBOCAL_WIRE_DECLARE(RobotJoint);

/// GET /v1/robots/{robot} (and the reply of POST /v1/robots).
struct Robot {
  std::string id;
  bool preset = false;
  std::string description;
  GeometryConvention convention = GeometryConvention::kStandardDh;
  int num_joints = 0;
  std::vector<RobotJoint> joints;
  PoseResultWire base;    // tracker (world) -> robot base
  PoseResultWire tool;    // flange -> tool
  PoseResultWire flange;  // last joint frame -> flange (identity but for an imported URDF's tip)
  /// For a robot imported from a URDF: its base and tip links.
  std::optional<UrdfChainWire> urdf;
  /// For a robot registered from a calibration: where it came from.
  std::optional<CalibrationSource> calibrated_from;
  /// The direction of gravity in the base frame (unit vector), and whether the links have masses.
  std::array<double, 3> gravity{0.0, 0.0, -1.0};
  bool has_masses = false;
  std::vector<std::string> error_parameters;
};
template <>
struct WireFields<Robot> {
  using S = Robot;
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id}, Field{"preset", &S::preset}, Field{"description", &S::description},
      Field{"convention", &S::convention}, Field{"num_joints", &S::num_joints},
      Computed<S>{"joints", &detail::WriteJoints<S>, &detail::ReadJoints<S>, true}, Field{"base", &S::base},
      Field{"tool", &S::tool}, Field{"flange", &S::flange}, Field{"urdf", &S::urdf, Presence::kOmitEmpty},
      Field{"calibrated_from", &S::calibrated_from, Presence::kOmitEmpty}, Field{"gravity", &S::gravity},
      Field{"has_masses", &S::has_masses}, Field{"error_parameters", &S::error_parameters});
};
ROBOCAL_WIRE_DECLARE(Robot);
/// The resource of a model.
Robot RobotFromModel(const std::string& id, const RobotModel& model, bool preset, const std::string& description);

/// GET /v1/robots: presets first, then registered robots in id order; next_page_token when there are more.
struct RobotList {
  std::vector<Robot> robots;
  std::optional<std::string> next_page_token;
};
template <>
struct WireFields<RobotList> {
  using S = RobotList;
  static constexpr auto fields =
      std::make_tuple(Field{"robots", &S::robots}, Field{"next_page_token", &S::next_page_token, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(RobotList);

/// POST /v1/robots/{robot}:forward and /v1/campaigns/{c}:forward: {"joints": [[...], ...]} (deg / mm per joint).
struct ForwardRequest {
  std::vector<std::vector<double>> joints;
  /// :forward of a calibration only: the payload the calibrated robot carries (a compliance model deflects
  /// under it); unset: the campaign's, or none.
  std::optional<PayloadWire> payload{};
};
/// Validates sizes and joint limits against `model`.
ForwardRequest ParseForwardRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits);
/// The same body, {"joints": [[...]]}, with 1 to max_vectors vectors within the robot's limits; a refusal's
/// message starts with `refusal` (e.g. "invalid forward request"). The parser of every joints-only request.
ForwardRequest ParseJointsRequest(const nlohmann::json& body, const RobotModel& model, std::size_t max_vectors,
                                  const char* refusal, bool with_payload = false);
template <>
struct WireFields<ForwardRequest> {
  using S = ForwardRequest;
  static constexpr auto fields =
      std::make_tuple(Field{"joints", &S::joints}, Field{"payload", &S::payload, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(ForwardRequest);

/// The reply of both forward calls: a robot's nominal poses (robot set, frame "world (nominal base)") or a
/// calibrated campaign's (campaign set, frame "tracker").
struct ForwardResult {
  std::optional<std::string> robot;
  std::optional<std::string> campaign;
  std::string frame;
  std::vector<PoseResultWire> poses;
};
template <>
struct WireFields<ForwardResult> {
  using S = ForwardResult;
  static constexpr auto fields = std::make_tuple(Field{"robot", &S::robot, Presence::kOmitEmpty},
                                                 Field{"campaign", &S::campaign, Presence::kOmitEmpty},
                                                 Field{"frame", &S::frame}, Field{"poses", &S::poses});
  static void Check(const S& result) {
    if (!result.robot && !result.campaign) throw WireError("robot or campaign", "required");
  }
};
ROBOCAL_WIRE_DECLARE(ForwardResult);

/// Joint values between the wire (deg / mm) and the core (rad / mm). Sizes must match the model.
Eigen::VectorXd JointsToCore(const RobotModel& model, const std::vector<double>& wire);
std::vector<double> JointsToWire(const RobotModel& model, const Eigen::VectorXd& q);
/// "deg" or "mm": the wire unit of joint `joint`.
const char* JointUnit(const RobotModel& model, int joint);

/// Checks a wire joint vector against the model (size, limits) and records violations at `path`.
bool CheckJoints(const RobotModel& model, const std::vector<double>& wire, const std::string& path, Problems* problems);
/// Reads a joint vector of a request at `path` (numbers, then CheckJoints).
bool ReadJointVector(const nlohmann::json& value, const std::string& path, const RobotModel& model, Problems* problems,
                     std::vector<double>* out);

}  // namespace robocal::api

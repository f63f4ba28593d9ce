// Wire shapes of the robot resources: registering a robot, the robot resource and its list, forward kinematics
// (of a robot or of a calibrated campaign), and joint vectors between wire units (deg / mm) and the core's.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/wire.h"
#include "robocal/core/robot_model.h"

namespace robocal::api {

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
};

/// Where an imported robot came from: the URDF document and the chain taken from it.
struct UrdfSource {
  std::string xml;
  std::string base_link;
  std::string tip_link;
};

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
  static constexpr auto fields = std::make_tuple(
      Field{"campaign", &S::campaign},
      Field{"robot", &S::robot},
      Field{"created_unix_ms", &S::created_unix_ms},
      Field{"joint_ranges", &S::joint_ranges, Presence::kOmitEmpty});
};

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
/// The definition as a request body (joints written in the convention's fields only).
void to_json(nlohmann::json& j, const RegisterRobotRequest& request);
/// Structural reading of a definition (no range checks: stored definitions stay readable when request
/// validation tightens).
void from_json(const nlohmann::json& j, RegisterRobotRequest& request);
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
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id, Presence::kOmitEmpty},
      Field{"description", &S::description, Presence::kOmitEmpty},
      Field{"urdf", &S::urdf},
      Field{"base_link", &S::base_link},
      Field{"tip_link", &S::tip_link},
      Field{"base", &S::base, Presence::kOmitEmpty},
      Field{"tool", &S::tool, Presence::kOmitEmpty});
};

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
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id},
      Field{"description", &S::description, Presence::kOmitEmpty},
      Field{"from_calibration", &S::campaign});
};

/// Why a joint's held terms are no robot joint's, in wire units (e.g. "harmonics_deg[0] 0.9 is beyond +-0.573
/// deg (0.01 rad)"), or empty: the bounds of RobotModel::Build (kImplausibleComplianceRadPerNm,
/// kImplausibleHarmonicRad).
std::string ImplausibleJointTerms(const JointWire& joint);

/// The core spec of a definition.
RobotModelSpec ToSpec(const RegisterRobotRequest& request);
/// A core joint in wire units (deg, mm).
JointWire JointToWire(const JointSpec& joint);
/// The definition that registers `spec`'s model under `id` (a table in the spec's convention, base and tool; no
/// preset, no URDF document): e.g. a calibrated DH table (GET /v1/campaigns/{c}/calibration?format=dh).
RegisterRobotRequest DefinitionOf(const std::string& id, const RobotModelSpec& spec, const std::string& description);
/// The model of a definition (throws ApiError kInvalidArgument naming the fields the core rejects).
RobotModel BuildModel(const RegisterRobotRequest& request);

/// One joint of the robot resource: the definition's fields (all geometry fields of the convention) plus its
/// unit ("deg" or "mm", the unit of its limits and of joint values on the wire).
struct RobotJoint {
  JointWire joint;
  std::string unit;
};

/// GET /v1/robots/{robot} (and the reply of POST /v1/robots).
struct Robot {
  std::string id;
  bool preset = false;
  std::string description;
  GeometryConvention convention = GeometryConvention::kStandardDh;
  int num_joints = 0;
  std::vector<RobotJoint> joints;
  PoseWire base;    // tracker (world) -> robot base
  PoseWire tool;    // flange -> tool
  PoseWire flange;  // last joint frame -> flange (identity but for an imported URDF's tip)
  /// For a robot imported from a URDF: its base and tip links (empty otherwise).
  std::string urdf_base_link, urdf_tip_link;
  /// For a robot registered from a calibration: where it came from.
  std::optional<CalibrationSource> calibrated_from;
  /// The direction of gravity in the base frame (unit vector), and whether the links have masses.
  std::array<double, 3> gravity{0.0, 0.0, -1.0};
  bool has_masses = false;
  std::vector<std::string> error_parameters;
};
void to_json(nlohmann::json& j, const Robot& robot);
void from_json(const nlohmann::json& j, Robot& robot);
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
  static constexpr auto fields = std::make_tuple(
      Field{"robots", &S::robots},
      Field{"next_page_token", &S::next_page_token, Presence::kOmitEmpty});
};

/// POST /v1/robots/{robot}:forward and /v1/campaigns/{c}:forward: {"joints": [[...], ...]} (deg / mm per joint).
struct ForwardRequest {
  std::vector<std::vector<double>> joints;
  /// :forward of a calibration only: the payload the calibrated robot carries (a compliance model deflects
  /// under it); unset: the campaign's, or none.
  std::optional<PayloadWire> payload;
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
  static constexpr auto fields = std::make_tuple(
      Field{"joints", &S::joints},
      Field{"payload", &S::payload, Presence::kOmitEmpty});
};

/// The reply of both forward calls: a robot's nominal poses (robot set, frame "world (nominal base)") or a
/// calibrated campaign's (campaign set, frame "tracker").
struct ForwardResult {
  std::optional<std::string> robot;
  std::optional<std::string> campaign;
  std::string frame;
  std::vector<PoseWire> poses;
};
void to_json(nlohmann::json& j, const ForwardResult& result);
void from_json(const nlohmann::json& j, ForwardResult& result);

/// Joint values between the wire (deg / mm) and the core (rad / mm). Sizes must match the model.
Eigen::VectorXd JointsToCore(const RobotModel& model, const std::vector<double>& wire);
std::vector<double> JointsToWire(const RobotModel& model, const Eigen::VectorXd& q);
/// "deg" or "mm": the wire unit of joint `joint`.
const char* JointUnit(const RobotModel& model, int joint);

/// Checks a wire joint vector against the model (size, limits) and records violations at `path`.
bool CheckJoints(const RobotModel& model, const std::vector<double>& wire, const std::string& path,
                 Problems* problems);
/// Reads a joint vector of a request at `path` (numbers, then CheckJoints).
bool ReadJointVector(const nlohmann::json& value, const std::string& path, const RobotModel& model,
                     Problems* problems, std::vector<double>* out);

}  // namespace robocal::api

// RobotModel: the immutable description of a serial robot, and the spec it is built and validated from.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

#include "robocal/core/transforms.h"

namespace robocal {

enum class JointType { kRevolute, kPrismatic };

/// How a joint's nominal fixed geometry is written in a RobotModelSpec.
enum class GeometryConvention {
  /// Standard (distal) Denavit-Hartenberg: T_{i-1,i} = Rz(theta_i + q) Tz(d_i) Tx(a_i) Rx(alpha_i)
  /// (prismatic: d_i + q).
  kStandardDh,
  /// Modified (proximal, Craig) DH: T_{i-1,i} = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i + q) Tz(d_i)
  /// (prismatic: d_i + q). Row i holds alpha_{i-1}, a_{i-1}, theta_i, d_i.
  kModifiedDh,
  /// A general fixed transform per joint, T_{i-1,i} = Trans(xyz) R(rpy) * motion(q), motion being a
  /// rotation about / translation along the joint frame's z axis (as URDF does with axis = z).
  kTransform,
};

const char* ToString(JointType type);
const char* ToString(GeometryConvention convention);

/// A joint's error map: the angle error of a revolute joint as a uniform cubic B-spline of its own angle,
///   e(q) = sum_k c_k B_k(u),  u = (clamp(q, first_knot, last_knot) - first_knot) / knot_spacing,
/// with knots every knot_spacing_rad from first_knot_rad and intervals() = coefficients - 3 intervals between them
/// (last_knot = first_knot + intervals * spacing). B_k is the uniform cubic B-spline that is non-zero on
/// intervals k - 3 .. k; on interval j the four non-zero ones are k = j .. j + 3. Beyond the knots the map is held
/// at its value at the nearer end (clamped): it was fitted over that range and says nothing beyond it. Gears
/// and encoders err with the angle at a few degrees' period, finer than a harmonic follows (docs/identification.md).
struct JointMap {
  double first_knot_rad = 0.0;
  double knot_spacing_rad = 0.0;
  std::vector<double> coefficients_rad;  ///< empty: no map
  bool empty() const { return coefficients_rad.empty(); }
  int intervals() const { return static_cast<int>(coefficients_rad.size()) - 3; }
  double last_knot_rad() const { return first_knot_rad + intervals() * knot_spacing_rad; }
  bool operator==(const JointMap& other) const {
    return first_knot_rad == other.first_knot_rad && knot_spacing_rad == other.knot_spacing_rad &&
           coefficients_rad == other.coefficients_rad;
  }
};

/// Knot spacings a map may have: below 0.5 deg the knots outnumber what a tracker resolves between poses; above
/// 90 deg a map is a poorer harmonic.
inline constexpr double kMinMapKnotSpacingRad = 0.5 * 3.14159265358979323846 / 180.0;
inline constexpr double kMaxMapKnotSpacingRad = 90.0 * 3.14159265358979323846 / 180.0;
/// The most intervals a map may have (a full four turns at 0.5 deg is 2880).
inline constexpr int kMaxMapIntervals = 2880;

/// One joint of a spec. Lengths in mm, angles in rad; joint values q in rad (revolute) or mm (prismatic).
struct JointSpec {
  std::string name;
  JointType type = JointType::kRevolute;
  // kStandardDh / kModifiedDh: the table row (theta is the joint-zero offset of a revolute joint, d that
  // of a prismatic joint).
  double a_mm = 0.0;
  double alpha_rad = 0.0;
  double d_mm = 0.0;
  double theta_rad = 0.0;
  // kTransform: the fixed transform from the previous joint frame (after its motion) to this joint frame.
  Eigen::Vector3d xyz_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d rpy_rad = Eigen::Vector3d::Zero();
  // Joint limits, in the joint's unit (rad or mm).
  double min = 0.0;
  double max = 0.0;
  /// Mass properties of the link this joint moves (up to the next joint): its mass (kg, >= 0; 0 with every
  /// other joint's 0 means the robot's masses are unknown) and its centre of mass (mm) in the link frame:
  /// the joint's frame after its motion (for standard DH: DH frame i, at the end of the row's fixed part).
  /// They give the gravity torques of the compliance model (joint_errors.h).
  double mass_kg = 0.0;
  Eigen::Vector3d com_mm = Eigen::Vector3d::Zero();
  /// Joint terms the robot holds as part of its kinematics (joint_errors.h), e.g. those of a calibration
  /// registered as a robot of its own: the compliance (rad per N*m; needs the robot's masses) and the harmonic
  /// amplitudes (rad) of sin q, cos q, sin 2q, cos 2q of the joint's own angle. The joint turns by
  /// compliance * tau + the harmonics on top of its command, before any error parameter's term. Zero: none;
  /// revolute joints only, within kImplausibleComplianceRadPerNm / kImplausibleHarmonicRad.
  double compliance_rad_per_nm = 0.0;
  Eigen::Vector4d harmonics_rad = Eigen::Vector4d::Zero();
  /// The error map the joint holds (revolute joints only; empty: none), on top of its command like the terms above.
  JointMap error_map = {};
};

/// Joint error maps as error parameters (JointMap): for each joint in `joints` (0-based, revolute, ascending), the
/// coefficients of a cubic B-spline of its angle error with knots every knot_spacing_rad over the range the
/// calibration poses cover, and a second-difference penalty of weight `smoothness` beside the measurements. A
/// map's constant is the joint's offset, which the geometric parameters hold: a fitted map's coefficients sum to
/// zero (a constraint row beside the penalty). The grid of each map (first knot, intervals) comes from the
/// measurements (WithTermsFor, identification.h) before a model with maps is built: RobotModel::Build refuses maps
/// without.
struct JointMapTerms {
  std::vector<int> joints;
  double knot_spacing_rad = 0.0;
  /// The penalty's weight relative to the measurements: 1 weighs a map's second difference as much as the
  /// measurements weigh one of its coefficients on average; 0 is no penalty. 0.01 by default: on the real UR10
  /// (Series B, 400 poses, knots every 4 deg on joints 1-5 with compliance) it leaves 0.102 mm held out, 0.1 leaves
  /// 0.135 and 1 leaves 0.216.
  double smoothness = 0.01;
  /// Per entry of `joints`: the map's first knot (rad) and its intervals. The penalty rows' scale, the
  /// measurements' mean information per coefficient, is each least-squares problem's own (it changes with the
  /// model error's estimate).
  std::vector<double> first_knot_rad;
  std::vector<int> intervals;
  bool empty() const { return joints.empty(); }
  bool resolved() const { return !joints.empty() && first_knot_rad.size() == joints.size(); }
  bool operator==(const JointMapTerms& other) const {
    return joints == other.joints && knot_spacing_rad == other.knot_spacing_rad && smoothness == other.smoothness &&
           first_knot_rad == other.first_knot_rad && intervals == other.intervals;
  }
};

/// Which joint errors beyond the geometric ones a model carries (joint_errors.h): one compliance per revolute
/// joint (a rotation about its axis proportional to the gravity torque on it), and harmonics of each revolute
/// joint's own angle up to `joint_harmonics` (0, 1 or 2). The default is the geometric model.
/// Joint error maps on `maps.joints` (JointMapTerms), which take no harmonics on the same robot (a map follows
/// them and more).
struct JointErrorTerms {
  bool compliance = false;
  int joint_harmonics = 0;
  JointMapTerms maps = {};
  bool operator==(const JointErrorTerms& other) const {
    return compliance == other.compliance && joint_harmonics == other.joint_harmonics && maps == other.maps;
  }
  bool operator!=(const JointErrorTerms& other) const { return !(*this == other); }
  /// "geometric", "compliance", "harmonics 2", "compliance + harmonics 1", "compliance + maps 4 deg (joints 1-5)".
  std::string Describe() const;
};

/// The highest joint harmonic order a model takes.
inline constexpr int kMaxJointHarmonics = 2;

/// Beyond these a joint term is no robot's: a compliance of 0.01 rad per N*m is a joint stiffness of 100 N*m/rad,
/// some hundred times softer than a small robot's wrist; a gear or encoder harmonic of 0.01 rad (0.57 deg) a
/// broken gear. A fit that identifies one is DEGRADED (and the model choice does not take its model); a robot
/// definition holding one is refused.
inline constexpr double kImplausibleComplianceRadPerNm = 1e-2;
inline constexpr double kImplausibleHarmonicRad = 1e-2;

/// A payload on the flange: its mass (kg, >= 0; 0 is no payload) and centre of mass (mm, flange frame).
struct Payload {
  double mass_kg = 0.0;
  Eigen::Vector3d com_mm = Eigen::Vector3d::Zero();
  bool operator==(const Payload& other) const { return mass_kg == other.mass_kg && com_mm == other.com_mm; }
  bool operator!=(const Payload& other) const { return !(*this == other); }
  /// A finite mass >= 0 and a finite centre of mass; else false and the field under `prefix` ("payload.mass_kg").
  bool IsValid(const std::string& prefix, std::string* error) const;
};

/// Everything needed to build a RobotModel. Plain data: edit a preset's spec, then build.
struct RobotModelSpec {
  std::string name;
  GeometryConvention convention = GeometryConvention::kStandardDh;
  std::vector<JointSpec> joints;
  /// World (tracker) frame -> robot base frame.
  Transform T_world_base = Transform::Identity();
  /// Last joint frame (after its motion) -> flange, for kTransform (e.g. a URDF's fixed joints after the last
  /// moving one, down to its tip link); the DH conventions derive it from their last row and require the
  /// identity here.
  Transform T_lastjoint_flange = Transform::Identity();
  /// Flange (last joint frame, after the last link's fixed geometry) -> tool frame. The tool frame's origin
  /// is the measured point (tracker reflector / tool centre point); its z axis is the tool axis.
  Transform T_flange_tool = Transform::Identity();
  /// The direction of gravity in the robot's base frame (a unit vector; a floor-mounted robot's -z).
  Eigen::Vector3d gravity_base = Eigen::Vector3d(0.0, 0.0, -1.0);
  /// The joint errors beyond geometry the model's error parameters include.
  JointErrorTerms error_terms;
};

/// One problem found in a spec: which field (e.g. "joints[2].max") and why.
struct FieldError {
  std::string field;
  std::string reason;
};

/// Thrown by RobotModel::Build for an invalid spec; lists every problem found, not only the first.
class InvalidModelError : public std::invalid_argument {
 public:
  explicit InvalidModelError(std::vector<FieldError> errors);
  const std::vector<FieldError>& errors() const { return errors_; }

 private:
  std::vector<FieldError> errors_;
};

/// Limits on the size of a spec accepted by RobotModel::Build.
inline constexpr int kMaxJoints = 12;

/// Where a group of six error parameters sits in the chain.
enum class ErrorSiteKind { kBase, kJoint, kTool };

/// The unit of an error parameter: a translation (mm), a rotation or joint angle (rad), or a compliance
/// (rad per N*m).
enum class ParameterUnit { kMm, kRad, kRadPerNm };

/// One error parameter beyond the geometric sites (RobotModelSpec::error_terms): joint `joint`'s compliance,
/// or the sine or cosine amplitude (rad) of its harmonic of order `order`.
/// Or coefficient `order` of its error map (JointMapTerms; parameter rad).
struct JointTermParameter {
  enum class Kind { kCompliance, kSin, kCos, kMap };
  Kind kind = Kind::kCompliance;
  int joint = 0;
  int order = 0;
};

/// An immutable serial robot model.
///
/// Internally every joint i (1..n) is a fixed transform F_i followed by its motion M_i(q_i), a rotation
/// about or translation along local z, whatever convention the spec used:
///
///   T_world_tool(q) = T_world_base * prod_i [F_i * M_i(q_i)] * F_flange * T_flange_tool
///
/// F_flange is the identity except for standard DH, where it holds the last row's fixed part.
/// Geometric errors are small transforms inserted at n + 2 sites (see error_model.h).
class RobotModel {
 public:
  /// Validates `spec` and builds the model. Throws InvalidModelError naming each bad field.
  static RobotModel Build(const RobotModelSpec& spec);

  const std::string& name() const { return spec_.name; }
  const RobotModelSpec& spec() const { return spec_; }
  int num_joints() const { return static_cast<int>(spec_.joints.size()); }
  JointType joint_type(int i) const { return spec_.joints[i].type; }
  const std::string& joint_name(int i) const { return spec_.joints[i].name; }
  const Eigen::VectorXd& lower_limits() const { return lower_; }
  const Eigen::VectorXd& upper_limits() const { return upper_; }
  /// True if every q_i lies in [min_i, max_i] (and q has num_joints() entries).
  bool WithinLimits(const Eigen::VectorXd& q) const;

  /// F_i for joint i (0-based): previous joint frame (after motion) -> joint frame (before motion).
  const Transform& fixed_transform(int i) const { return fixed_[i]; }
  /// Last joint frame (after motion) -> flange.
  const Transform& T_lastjoint_flange() const { return flange_; }
  const Transform& T_world_base() const { return spec_.T_world_base; }
  const Transform& T_flange_tool() const { return spec_.T_flange_tool; }

  /// Error parameters: 6 per site, sites ordered base, joints 1..n, tool (the geometric ones), then the joint
  /// terms of spec().error_terms: every revolute joint's compliance, then every revolute joint's harmonics
  /// (order 1 sine, cosine, order 2 sine, cosine), then the map coefficients of each mapped joint in turn.
  int num_error_sites() const { return num_joints() + 2; }
  int num_geometric_parameters() const { return 6 * num_error_sites(); }
  int num_error_parameters() const { return static_cast<int>(parameter_names_.size()); }
  /// The joint terms, in parameter order: parameter num_geometric_parameters() + t is joint_terms()[t].
  const std::vector<JointTermParameter>& joint_terms() const { return joint_terms_; }
  const JointErrorTerms& error_terms() const { return spec_.error_terms; }
  /// Name of error parameter k, e.g. "base.dx", "joint3.rz", "tool.dz", "joint2.compliance", "joint4.sin1",
  /// "joint5.map17".
  const std::string& parameter_name(int k) const { return parameter_names_[k]; }
  const std::vector<std::string>& parameter_names() const { return parameter_names_; }
  /// Index of a parameter by name, or -1.
  int ParameterIndex(const std::string& name) const;
  /// For a geometric parameter k (k < num_geometric_parameters()): true if it is a translation (mm), false for a
  /// rotation (rad). parameter_unit() covers every parameter.
  static bool IsTranslationParameter(int k) { return k % 6 < 3; }
  /// Whether error parameter k is a joint's offset: its site's error sits just before the joint's motion about
  /// (along) its z axis, so rz (dz for a prismatic joint) of a joint's site is its offset.
  bool IsJointOffsetParameter(int k) const;
  ParameterUnit parameter_unit(int k) const;
  /// Whether any link has a mass (the compliance model needs them).
  bool has_masses() const;
  /// Per joint: the index of its first map coefficient among the error parameters, or -1 (no map term).
  int map_parameter(int joint) const { return map_first_[static_cast<size_t>(joint)]; }
  /// Whether any joint holds fixed joint terms (JointSpec::compliance_rad_per_nm, harmonics_rad, error_map).
  bool has_fixed_joint_terms() const { return has_fixed_joint_terms_; }
  /// Whether the joints deflect: fixed joint terms, or joint-term error parameters.
  bool deflects() const { return has_fixed_joint_terms_ || !joint_terms_.empty(); }
  /// Link frame i (JointSpec::com_mm's frame) relative to joint i's frame after its motion: the identity
  /// except for standard DH, where it is the row's fixed part.
  const Transform& link_frame(int i) const { return link_frame_[i]; }
  /// The same robot with other joint error terms (the geometry, masses and limits kept).
  RobotModel WithErrorTerms(const JointErrorTerms& terms) const;

 private:
  RobotModel() = default;

  RobotModelSpec spec_;
  std::vector<Transform> fixed_;
  Transform flange_ = Transform::Identity();
  Eigen::VectorXd lower_, upper_;
  std::vector<std::string> parameter_names_;
  std::vector<JointTermParameter> joint_terms_;
  std::vector<Transform> link_frame_;
  std::vector<int> map_first_;
  bool has_fixed_joint_terms_ = false;
};

}  // namespace robocal

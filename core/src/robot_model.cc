// RobotModel construction and validation.
#include "robocal/core/robot_model.h"

#include <cmath>
#include <set>
#include <sstream>

namespace robocal {
namespace {

std::string JoinErrors(const std::vector<FieldError>& errors) {
  std::ostringstream out;
  out << "invalid robot model";
  for (const FieldError& e : errors) out << "; " << e.field << ": " << e.reason;
  return out.str();
}

std::string Num(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

void CheckTransform(const Transform& t, const std::string& field, std::vector<FieldError>* errors) {
  if (!t.matrix().allFinite()) {
    errors->push_back({field, "must contain only finite numbers"});
  } else if (!IsValidRigidTransform(t, 1e-6)) {
    errors->push_back({field, "rotation must be orthonormal with determinant +1"});
  } else if (t.matrix().row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
    errors->push_back({field, "last row must be [0 0 0 1]"});
  }
}

void ValidateMap(const JointMap& map, const std::string& prefix, std::vector<FieldError>* errors) {
  if (!std::isfinite(map.first_knot_rad)) errors->push_back({prefix + ".first_knot", "must be a finite number"});
  if (!(map.knot_spacing_rad >= kMinMapKnotSpacingRad * (1 - 1e-12) &&
        map.knot_spacing_rad <= kMaxMapKnotSpacingRad * (1 + 1e-12))) {
    errors->push_back({prefix + ".knot_spacing",
                       "must be in [0.5, 90] degrees, got " + Num(map.knot_spacing_rad * 180.0 / M_PI) + " degrees"});
  }
  if (map.intervals() < 1 || map.intervals() > kMaxMapIntervals) {
    errors->push_back({prefix + ".coefficients", "a cubic map has intervals + 3 coefficients, 4 to " +
                                                     std::to_string(kMaxMapIntervals + 3) + ", got " +
                                                     std::to_string(map.coefficients_rad.size())});
  }
  for (size_t k = 0; k < map.coefficients_rad.size(); ++k) {
    const double c = map.coefficients_rad[k];
    if (!std::isfinite(c) || std::abs(c) > kImplausibleHarmonicRad) {
      errors->push_back({prefix + ".coefficients[" + std::to_string(k) + "]",
                         "must be a finite angle within " + Num(kImplausibleHarmonicRad) +
                             " rad, no gear's or encoder's error beyond, got " + Num(c)});
      break;
    }
  }
}

// The map terms of a model (JointMapTerms): on revolute joints, ascending, with a grid each once resolved.
void ValidateMapTerms(const RobotModelSpec& spec, std::vector<FieldError>* errors) {
  const JointMapTerms& maps = spec.error_terms.maps;
  if (maps.empty()) return;
  const int n = static_cast<int>(spec.joints.size());
  for (size_t k = 0; k < maps.joints.size(); ++k) {
    const int j = maps.joints[k];
    const std::string field = "model.joint_maps.joints[" + std::to_string(k) + "]";
    if (j < 0 || j >= n) {
      errors->push_back(
          {field, "joint " + std::to_string(j + 1) + " is not one of the robot's " + std::to_string(n) + " joints"});
    } else if (spec.joints[j].type != JointType::kRevolute) {
      errors->push_back({field, "joint " + std::to_string(j + 1) + " ('" + spec.joints[j].name +
                                    "') is prismatic: error maps are for revolute joints"});
    } else if (k > 0 && j <= maps.joints[k - 1]) {
      errors->push_back({field, "joints must be ascending and each once"});
    }
  }
  if (!(maps.knot_spacing_rad >= kMinMapKnotSpacingRad * (1 - 1e-12) &&
        maps.knot_spacing_rad <= kMaxMapKnotSpacingRad * (1 + 1e-12))) {
    errors->push_back({"model.joint_maps.knot_spacing_deg",
                       "must be in [0.5, 90] degrees, got " + Num(maps.knot_spacing_rad * 180.0 / M_PI)});
  }
  if (!(maps.smoothness >= 0.0) || !std::isfinite(maps.smoothness)) {
    errors->push_back({"model.joint_maps.smoothness", "must be a finite number >= 0, got " + Num(maps.smoothness)});
  }
  if (spec.error_terms.joint_harmonics > 0) {
    errors->push_back({"model.joint_maps",
                       "a model with joint maps takes no joint_harmonics (a map follows a "
                       "joint's harmonics and errors finer than them)"});
  }
  if (!maps.resolved()) {
    errors->push_back({"model.joint_maps",
                       "the maps' knots are not placed yet (ResolveJointMaps places them over "
                       "the calibration poses)"});
    return;
  }
  if (maps.intervals.size() != maps.joints.size()) {
    errors->push_back({"model.joint_maps", "one grid per mapped joint"});
    return;
  }
  for (size_t k = 0; k < maps.joints.size(); ++k) {
    if (!std::isfinite(maps.first_knot_rad[k]) || maps.intervals[k] < 1 || maps.intervals[k] > kMaxMapIntervals) {
      errors->push_back({"model.joint_maps", "map " + std::to_string(k) + ": a finite first knot and 1 to " +
                                                 std::to_string(kMaxMapIntervals) + " intervals"});
    }
  }
}

void ValidateJoint(const JointSpec& joint, int i, GeometryConvention convention, std::set<std::string>* names,
                   std::vector<FieldError>* errors) {
  const std::string prefix = "joints[" + std::to_string(i) + "]";
  if (joint.name.empty()) {
    errors->push_back({prefix + ".name", "must not be empty"});
  } else if (joint.name == "base" || joint.name == "tool") {
    errors->push_back({prefix + ".name", "'" + joint.name + "' is reserved for the base and tool error sites"});
  } else if (joint.name.find_first_of(". \t\n") != std::string::npos) {
    errors->push_back({prefix + ".name", "must not contain '.' or white space"});
  } else if (!names->insert(joint.name).second) {
    errors->push_back({prefix + ".name", "duplicate joint name '" + joint.name + "'"});
  }
  auto finite = [&](double v, const char* field) {
    if (!std::isfinite(v)) errors->push_back({prefix + "." + field, "must be a finite number"});
  };
  if (convention == GeometryConvention::kTransform) {
    for (int k = 0; k < 3; ++k) {
      finite(joint.xyz_mm[k], "xyz_mm");
      finite(joint.rpy_rad[k], "rpy_rad");
    }
  } else {
    finite(joint.a_mm, "a_mm");
    finite(joint.alpha_rad, "alpha_rad");
    finite(joint.d_mm, "d_mm");
    finite(joint.theta_rad, "theta_rad");
  }
  const bool min_ok = std::isfinite(joint.min);
  const bool max_ok = std::isfinite(joint.max);
  if (!min_ok) errors->push_back({prefix + ".min", "must be a finite number"});
  if (!max_ok) errors->push_back({prefix + ".max", "must be a finite number"});
  if (min_ok && max_ok && !(joint.min < joint.max)) {
    errors->push_back(
        {prefix + ".max", "must be greater than min (min " + Num(joint.min) + ", max " + Num(joint.max) + ")"});
  }
  if (!std::isfinite(joint.mass_kg) || joint.mass_kg < 0.0) {
    errors->push_back({prefix + ".mass_kg", "must be a finite number >= 0 (kg), got " + Num(joint.mass_kg)});
  }
  if (!joint.com_mm.allFinite()) errors->push_back({prefix + ".com_mm", "must contain only finite numbers"});
  if (!std::isfinite(joint.compliance_rad_per_nm)) {
    errors->push_back({prefix + ".compliance", "must be a finite number"});
  } else if (std::abs(joint.compliance_rad_per_nm) > kImplausibleComplianceRadPerNm) {
    errors->push_back({prefix + ".compliance", "beyond " + Num(kImplausibleComplianceRadPerNm) +
                                                   " rad per N*m, no robot joint's compliance, got " +
                                                   Num(joint.compliance_rad_per_nm)});
  }
  if (!joint.harmonics_rad.allFinite()) {
    errors->push_back({prefix + ".harmonics", "must contain only finite numbers"});
  } else if (joint.harmonics_rad.cwiseAbs().maxCoeff() > kImplausibleHarmonicRad) {
    errors->push_back({prefix + ".harmonics", "an amplitude beyond " + Num(kImplausibleHarmonicRad) +
                                                  " rad, no robot joint's harmonic, got " +
                                                  Num(joint.harmonics_rad.cwiseAbs().maxCoeff())});
  }
  if (joint.type != JointType::kRevolute &&
      (joint.compliance_rad_per_nm != 0.0 || !joint.harmonics_rad.isZero(0.0) || !joint.error_map.empty())) {
    errors->push_back({prefix + ".type", "a prismatic joint holds no joint terms (compliance, harmonics, error map)"});
  }
  if (!joint.error_map.empty()) ValidateMap(joint.error_map, prefix + ".error_map", errors);
  // Four turns: industrial wrists turn +-400 degrees (ABB) and more; a range beyond is a unit error.
  if (joint.type == JointType::kRevolute && min_ok && max_ok && (joint.max - joint.min) > 8.0 * M_PI + 1e-9) {
    errors->push_back({prefix + ".max", "revolute range max - min must not exceed 1440 degrees (four turns)"});
  }
}

Transform Motionless(const JointSpec& j, GeometryConvention convention) {
  switch (convention) {
    case GeometryConvention::kStandardDh:
      // Rz(theta) Tz(d) Tx(a) Rx(alpha): the part of the row that follows the joint's motion.
      return Rotation(RotZ(j.theta_rad)) * Translation(0, 0, j.d_mm) * Translation(j.a_mm, 0, 0) *
             Rotation(RotX(j.alpha_rad));
    case GeometryConvention::kModifiedDh:
      return Rotation(RotX(j.alpha_rad)) * Translation(j.a_mm, 0, 0) * Rotation(RotZ(j.theta_rad)) *
             Translation(0, 0, j.d_mm);
    case GeometryConvention::kTransform:
      return TransformFromXyzRpy(j.xyz_mm, j.rpy_rad);
  }
  return Transform::Identity();
}

}  // namespace

const char* ToString(JointType type) { return type == JointType::kRevolute ? "revolute" : "prismatic"; }

const char* ToString(GeometryConvention convention) {
  switch (convention) {
    case GeometryConvention::kStandardDh:
      return "dh";
    case GeometryConvention::kModifiedDh:
      return "mdh";
    case GeometryConvention::kTransform:
      return "transform";
  }
  return "?";
}

InvalidModelError::InvalidModelError(std::vector<FieldError> errors)
    : std::invalid_argument(JoinErrors(errors)), errors_(std::move(errors)) {}

RobotModel RobotModel::Build(const RobotModelSpec& spec) {
  std::vector<FieldError> errors;
  if (spec.name.empty()) errors.push_back({"name", "must not be empty"});
  const int n = static_cast<int>(spec.joints.size());
  if (n == 0) errors.push_back({"joints", "must contain at least one joint"});
  if (n > kMaxJoints) {
    errors.push_back({"joints", "at most " + std::to_string(kMaxJoints) + " joints, got " + std::to_string(n)});
  }
  std::set<std::string> names;
  for (int i = 0; i < n; ++i) ValidateJoint(spec.joints[i], i, spec.convention, &names, &errors);
  CheckTransform(spec.T_world_base, "base", &errors);
  CheckTransform(spec.T_flange_tool, "tool", &errors);
  CheckTransform(spec.T_lastjoint_flange, "flange", &errors);
  if (spec.convention != GeometryConvention::kTransform && !spec.T_lastjoint_flange.matrix().isIdentity(0.0)) {
    errors.push_back({"flange", "only the transform convention takes a flange transform (DH derives it)"});
  }
  if (!spec.gravity_base.allFinite() || std::abs(spec.gravity_base.norm() - 1.0) > 1e-6) {
    errors.push_back({"gravity", "must be a unit vector (the direction of gravity in the base frame)"});
  }
  bool masses = false, fixed_compliance = false;
  for (const JointSpec& j : spec.joints) {
    masses = masses || j.mass_kg > 0.0;
    fixed_compliance = fixed_compliance || j.compliance_rad_per_nm != 0.0;
  }
  if (fixed_compliance && !masses) {
    errors.push_back({"joints",
                      "a joint's compliance needs the links' masses (mass_kg, com_mm): without them there "
                      "is no gravity torque to deflect it"});
  }
  if (spec.error_terms.joint_harmonics < 0 || spec.error_terms.joint_harmonics > kMaxJointHarmonics) {
    errors.push_back({"model.joint_harmonics", "must be 0, 1 or " + std::to_string(kMaxJointHarmonics) + ", got " +
                                                   std::to_string(spec.error_terms.joint_harmonics)});
  }
  ValidateMapTerms(spec, &errors);
  if (!errors.empty()) throw InvalidModelError(std::move(errors));

  RobotModel model;
  model.spec_ = spec;
  model.fixed_.resize(n, Transform::Identity());
  if (spec.convention == GeometryConvention::kTransform) model.flange_ = spec.T_lastjoint_flange;
  model.lower_.resize(n);
  model.upper_.resize(n);
  model.link_frame_.assign(n, Transform::Identity());
  for (int i = 0; i < n; ++i) {
    const JointSpec& j = spec.joints[i];
    model.has_fixed_joint_terms_ = model.has_fixed_joint_terms_ || j.compliance_rad_per_nm != 0.0 ||
                                   !j.harmonics_rad.isZero(0.0) || !j.error_map.empty();
    model.lower_[i] = j.min;
    model.upper_[i] = j.max;
    const Transform fixed = Motionless(j, spec.convention);
    if (spec.convention == GeometryConvention::kStandardDh) model.link_frame_[i] = fixed;
    if (spec.convention == GeometryConvention::kStandardDh) {
      // In standard DH the motion comes first in each row (Rz(q) and Tz(q) commute with Rz(theta) Tz(d)),
      // so the row's fixed part belongs before the *next* joint's motion.
      if (i + 1 < n) {
        model.fixed_[i + 1] = fixed;
      } else {
        model.flange_ = fixed;
      }
    } else {
      model.fixed_[i] = fixed;
    }
  }

  static const char* const kSuffix[6] = {"dx", "dy", "dz", "rx", "ry", "rz"};
  auto add_site = [&](const std::string& site) {
    for (const char* s : kSuffix) model.parameter_names_.push_back(site + "." + s);
  };
  add_site("base");
  for (const JointSpec& j : spec.joints) add_site(j.name);
  add_site("tool");
  using Kind = JointTermParameter::Kind;
  if (spec.error_terms.compliance) {
    for (int i = 0; i < n; ++i) {
      if (spec.joints[i].type != JointType::kRevolute) continue;
      model.joint_terms_.push_back({Kind::kCompliance, i, 0});
      model.parameter_names_.push_back(spec.joints[i].name + ".compliance");
    }
  }
  for (int i = 0; i < n; ++i) {
    if (spec.joints[i].type != JointType::kRevolute) continue;
    for (int k = 1; k <= spec.error_terms.joint_harmonics; ++k) {
      model.joint_terms_.push_back({Kind::kSin, i, k});
      model.parameter_names_.push_back(spec.joints[i].name + ".sin" + std::to_string(k));
      model.joint_terms_.push_back({Kind::kCos, i, k});
      model.parameter_names_.push_back(spec.joints[i].name + ".cos" + std::to_string(k));
    }
  }
  model.map_first_.assign(static_cast<size_t>(n), -1);
  const JointMapTerms& maps = spec.error_terms.maps;
  for (size_t m = 0; m < maps.joints.size(); ++m) {
    const int i = maps.joints[m];
    model.map_first_[static_cast<size_t>(i)] = static_cast<int>(model.parameter_names_.size());
    for (int k = 0; k < maps.intervals[m] + 3; ++k) {
      model.joint_terms_.push_back({Kind::kMap, i, k});
      model.parameter_names_.push_back(spec.joints[i].name + ".map" + std::to_string(k));
    }
  }
  return model;
}

std::string JointErrorTerms::Describe() const {
  std::string out = compliance ? "compliance" : "";
  if (joint_harmonics > 0) {
    out += (out.empty() ? "" : " + ") + std::string("harmonics ") + std::to_string(joint_harmonics);
  }
  if (!maps.empty()) {
    std::ostringstream m;
    m << "maps " << maps.knot_spacing_rad * 180.0 / M_PI << " deg, smoothness " << maps.smoothness << " (joint"
      << (maps.joints.size() > 1 ? "s" : "");
    for (size_t k = 0; k < maps.joints.size(); ++k) m << (k ? "," : " ") << maps.joints[k] + 1;
    m << ")";
    out += (out.empty() ? "" : " + ") + m.str();
  }
  return out.empty() ? "geometric" : out;
}

bool Payload::IsValid(const std::string& prefix, std::string* error) const {
  if (!std::isfinite(mass_kg) || mass_kg < 0.0) {
    *error = prefix + ".mass_kg: must be a finite number >= 0 (kg), got " + Num(mass_kg);
    return false;
  }
  if (!com_mm.allFinite()) {
    *error = prefix + ".com_mm: must contain only finite numbers";
    return false;
  }
  return true;
}

ParameterUnit RobotModel::parameter_unit(int k) const {
  if (k < num_geometric_parameters()) return IsTranslationParameter(k) ? ParameterUnit::kMm : ParameterUnit::kRad;
  return joint_terms_[k - num_geometric_parameters()].kind == JointTermParameter::Kind::kCompliance
             ? ParameterUnit::kRadPerNm
             : ParameterUnit::kRad;
}

bool RobotModel::has_masses() const {
  for (const JointSpec& j : spec_.joints) {
    if (j.mass_kg > 0.0) return true;
  }
  return false;
}

RobotModel RobotModel::WithErrorTerms(const JointErrorTerms& terms) const {
  RobotModelSpec spec = spec_;
  spec.error_terms = terms;
  return Build(spec);
}

bool RobotModel::WithinLimits(const Eigen::VectorXd& q) const {
  if (q.size() != num_joints()) return false;
  for (int i = 0; i < num_joints(); ++i) {
    if (!(q[i] >= lower_[i] && q[i] <= upper_[i])) return false;
  }
  return true;
}

bool RobotModel::IsJointOffsetParameter(int k) const {
  const int site = k / 6;
  if (k < 0 || k >= num_geometric_parameters() || site == 0 || site == num_error_sites() - 1) return false;
  return joint_type(site - 1) == JointType::kRevolute ? k % 6 == 5 : k % 6 == 2;
}

int RobotModel::ParameterIndex(const std::string& name) const {
  for (int k = 0; k < num_error_parameters(); ++k) {
    if (parameter_names_[k] == name) return k;
  }
  return -1;
}

}  // namespace robocal

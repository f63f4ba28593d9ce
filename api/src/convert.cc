// Core results -> wire JSON.
#include "robocal/api/convert.h"

#include <cmath>
#include <numbers>

namespace robocal::api {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

nlohmann::json Vec(const Eigen::VectorXd& v) {
  nlohmann::json a = nlohmann::json::array();
  for (int i = 0; i < v.size(); ++i) a.push_back(Num(v[i]));
  return a;
}

nlohmann::json Stats(const ErrorStatistics& s, double scale) {
  return {{"count", s.count}, {"mean", Num(s.mean * scale)}, {"std", Num(s.std * scale)},
          {"max", Num(s.max * scale)}, {"rp", Num(s.rp * scale)}};
}

}  // namespace

nlohmann::json Num(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(); }

Transform PoseToTransform(const PoseWire& p) {
  Transform t = Transform::Identity();
  t.translation() = Eigen::Vector3d(p.position_mm[0], p.position_mm[1], p.position_mm[2]);
  t.linear() = Eigen::Quaterniond(p.quaternion[0], p.quaternion[1], p.quaternion[2], p.quaternion[3])
                   .normalized()
                   .toRotationMatrix();
  return t;
}

PoseWire TransformToPose(const Transform& pose) {
  PoseWire p;
  const Eigen::Vector3d t = pose.translation();
  p.position_mm = {t.x(), t.y(), t.z()};
  Eigen::Quaterniond q(pose.linear());
  q.normalize();
  // One sign per rotation, so that equal poses serialise equally.
  if (q.w() < 0) q.coeffs() *= -1.0;
  p.quaternion = {q.w(), q.x(), q.y(), q.z()};
  return p;
}

nlohmann::json PoseToJson(const Transform& pose) {
  nlohmann::json j = ToJson(TransformToPose(pose));
  const Eigen::Vector3d rpy = RpyFromRotation(pose.linear()) * kDegPerRad;
  j["rpy_deg"] = {rpy.x(), rpy.y(), rpy.z()};
  return j;
}

nlohmann::json RobotToJson(const std::string& id, const RobotModel& model, bool preset,
                           const std::string& description) {
  const RobotModelSpec& spec = model.spec();
  nlohmann::json joints = nlohmann::json::array();
  for (int i = 0; i < model.num_joints(); ++i) {
    const JointSpec& js = spec.joints[i];
    const bool revolute = js.type == JointType::kRevolute;
    const double scale = revolute ? kDegPerRad : 1.0;
    nlohmann::json j = {{"name", js.name}, {"type", revolute ? "revolute" : "prismatic"},
                        {"unit", revolute ? "deg" : "mm"}};
    if (spec.convention == GeometryConvention::kTransform) {
      j["xyz_mm"] = {js.xyz_mm.x(), js.xyz_mm.y(), js.xyz_mm.z()};
      j["rpy_deg"] = {js.rpy_rad.x() * kDegPerRad, js.rpy_rad.y() * kDegPerRad, js.rpy_rad.z() * kDegPerRad};
    } else {
      j["a_mm"] = js.a_mm;
      j["alpha_deg"] = js.alpha_rad * kDegPerRad;
      j["d_mm"] = js.d_mm;
      j["theta_deg"] = js.theta_rad * kDegPerRad;
    }
    j[revolute ? "min_deg" : "min_mm"] = js.min * scale;
    j[revolute ? "max_deg" : "max_mm"] = js.max * scale;
    joints.push_back(j);
  }
  const char* convention = spec.convention == GeometryConvention::kModifiedDh  ? "mdh"
                           : spec.convention == GeometryConvention::kTransform ? "transform"
                                                                               : "dh";
  return {{"id", id},
          {"preset", preset},
          {"description", description},
          {"convention", convention},
          {"num_joints", model.num_joints()},
          {"joints", joints},
          {"base", PoseToJson(spec.T_world_base)},
          {"tool", PoseToJson(spec.T_flange_tool)},
          {"error_parameters", model.parameter_names()}};
}

nlohmann::json IndicesToJson(const ObservabilityIndices& x) {
  return {{"num_configurations", x.num_configurations},
          {"num_parameters", x.num_parameters},
          {"condition_number", Num(x.condition_number)},
          {"o1", Num(x.o1)},
          {"o2", Num(x.o2)},
          {"o3", Num(x.o3)},
          {"o4", Num(x.o4)},
          {"o5", Num(x.o5)},
          {"log_det", Num(x.log_det)},
          {"singular_values", Vec(x.singular_values)},
          {"scaling", x.scaling}};
}

nlohmann::json PlanSummaryToJson(const PlanSummary& s) {
  return {{"termination", ToString(s.termination)},
          {"message", s.message},
          {"method", s.method},
          {"objective", ToString(s.objective)},
          {"iterations", s.iterations},
          {"evaluations", s.evaluations},
          {"seconds", Num(s.seconds)},
          {"initial", IndicesToJson(s.initial)},
          {"brief", s.BriefReport()}};
}

nlohmann::json PredictedAccuracyToJson(const PredictedAccuracy& a) {
  nlohmann::json j = {{"num_validation", a.num_validation},
                      {"rms_position_mm", Num(a.rms_position_mm)},
                      {"max_position_mm", Num(a.max_position_mm)}};
  j["rms_orientation_deg"] = a.has_orientation ? Num(a.rms_orientation_rad * kDegPerRad) : nlohmann::json();
  return j;
}

nlohmann::json DroppedToJson(const std::vector<DroppedParameter>& dropped) {
  nlohmann::json a = nlohmann::json::array();
  for (const DroppedParameter& d : dropped) a.push_back({{"name", d.name}, {"reason", d.reason}});
  return a;
}

nlohmann::json NoiseToJson(const NoiseWire& n) {
  return {{"position_mm", n.position_mm}, {"orientation_deg", n.orientation_deg}};
}

nlohmann::json ResidualsToJson(const ResidualStatistics& s) {
  return {{"num_measurements", s.num_measurements},
          {"rms_position_mm", Num(s.rms_position_mm)},
          {"max_position_mm", Num(s.max_position_mm)},
          {"rms_orientation_deg", Num(s.rms_orientation_rad * kDegPerRad)},
          {"max_orientation_deg", Num(s.max_orientation_rad * kDegPerRad)},
          {"rms_weighted", Num(s.rms_weighted)}};
}

nlohmann::json CalibrationToJson(const Calibration& c) {
  nlohmann::json params = nlohmann::json::array();
  for (const IdentifiedParameter& p : c.parameters) {
    const bool translation = RobotModel::IsTranslationParameter(p.index);
    const double scale = translation ? 1.0 : kDegPerRad;
    params.push_back({{"name", p.name}, {"unit", translation ? "mm" : "deg"}, {"value", Num(p.value * scale)},
                      {"std", Num(p.std * scale)}});
  }
  const IdentificationSummary& s = c.summary;
  return {{"parameters", params},
          {"dropped", DroppedToJson(s.dropped)},
          {"base", PoseToJson(c.T_world_base)},
          {"tool", PoseToJson(c.T_flange_tool)},
          {"registered_base", PoseToJson(c.model.T_world_base())},
          {"residuals_before", ResidualsToJson(s.before)},
          {"residuals_after", ResidualsToJson(s.after)},
          {"condition_number", Num(s.condition_number)},
          {"scaling", s.scaling},
          {"summary",
           {{"termination", ToString(s.termination)},
            {"message", s.message},
            {"measurement_type", ToString(s.measurement_type)},
            {"num_measurements", s.num_measurements},
            {"num_poses", s.num_poses},
            {"num_parameters", s.num_parameters},
            {"iterations", s.iterations},
            {"initial_cost", Num(s.initial_cost)},
            {"final_cost", Num(s.final_cost)},
            {"sigma_hat", Num(s.sigma_hat)},
            {"seconds", Num(s.seconds)},
            {"brief", s.BriefReport()}}}};
}

nlohmann::json CompensationResultToJson(const RobotModel& model, const CompensationResult& r) {
  nlohmann::json joints = nlohmann::json::array();
  if (r.joints.size() == model.num_joints()) {
    for (double v : JointsToWire(model, r.joints)) joints.push_back(Num(v));
  }
  return {{"joints", joints},
          {"position_error_mm", Num(r.position_error_mm)},
          {"orientation_error_deg", Num(r.orientation_error_rad * kDegPerRad)},
          {"free_rotation_deg", Num(r.free_rotation_rad * kDegPerRad)},
          {"converged", r.converged},
          {"iterations", r.iterations},
          {"message", r.message}};
}

nlohmann::json AccuracyReportToJson(const AccuracyReport& r) {
  return {{"h_mm", r.h_mm},
          {"e_xyz_mm", Stats(r.e_xyz_mm, 1.0)},
          {"e_cos_deg", Stats(r.e_cos_rad, kDegPerRad)},
          {"e_tot_mm", Stats(r.e_tot_mm, 1.0)}};
}

}  // namespace robocal::api

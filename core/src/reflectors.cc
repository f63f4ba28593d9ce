// Reflectors on the tool: validation, parameter names, and the geometry of a reflector's point.
#include "robocal/core/reflectors.h"

#include <set>
#include <stdexcept>

namespace robocal {

bool ValidateReflectors(const std::vector<Reflector>& reflectors, std::string* error) {
  if (reflectors.size() > static_cast<size_t>(kMaxFitReflectors)) {
    *error =
        "reflectors: at most " + std::to_string(kMaxFitReflectors) + " (got " + std::to_string(reflectors.size()) + ")";
    return false;
  }
  std::set<std::string> ids;
  for (size_t k = 0; k < reflectors.size(); ++k) {
    const std::string field = "reflectors[" + std::to_string(k) + "]";
    const Reflector& r = reflectors[k];
    if (r.id.empty() || r.id.size() > 64) {
      *error = field + ".id must have 1 to 64 characters";
      return false;
    }
    if (!ids.insert(r.id).second) {
      *error = field + ".id \"" + r.id + "\" is given twice";
      return false;
    }
    if (!r.position_mm.allFinite()) {
      *error = field + ".position_mm must be finite";
      return false;
    }
  }
  return true;
}

std::string ParameterName(const RobotModel& model, const std::vector<Reflector>& reflectors, int index) {
  const int n = model.num_error_parameters();
  if (index >= 0 && index < n) return model.parameter_name(index);
  const int k = (index - n) / 3;
  if (index < n || k >= static_cast<int>(reflectors.size())) {
    throw std::out_of_range("ParameterName: index " + std::to_string(index) +
                            " is neither the model's nor a reflector's");
  }
  static const char* const kAxes[] = {"dx", "dy", "dz"};
  return "reflector." + reflectors[k].id + "." + kAxes[(index - n) % 3];
}

int ParameterIndex(const RobotModel& model, const std::vector<Reflector>& reflectors, const std::string& name) {
  const int index = model.ParameterIndex(name);
  if (index >= 0) return index;
  const int n = model.num_error_parameters();
  for (size_t k = 0; k < reflectors.size(); ++k) {
    for (int axis = 0; axis < 3; ++axis) {
      const int j = n + 3 * static_cast<int>(k) + axis;
      if (ParameterName(model, reflectors, j) == name) return j;
    }
  }
  return -1;
}

std::vector<Eigen::Vector3d> ReflectorsInTool(const RobotModel& nominal, const std::vector<Reflector>& reflectors,
                                              const Eigen::VectorXd& offset_errors) {
  if (offset_errors.size() != 0 && offset_errors.size() != 3 * static_cast<Eigen::Index>(reflectors.size())) {
    throw std::invalid_argument("ReflectorsInTool: offset_errors must be empty or 3 per reflector");
  }
  const Transform flange_to_tool = nominal.T_flange_tool().inverse();
  std::vector<Eigen::Vector3d> out;
  out.reserve(reflectors.size());
  for (size_t k = 0; k < reflectors.size(); ++k) {
    Eigen::Vector3d p = reflectors[k].position_mm;
    if (offset_errors.size() != 0) p += offset_errors.segment<3>(3 * static_cast<Eigen::Index>(k));
    out.push_back(flange_to_tool * p);
  }
  return out;
}

Transform AtReflector(const Transform& T_world_tool, const Eigen::Vector3d& in_tool) {
  Transform out = T_world_tool;
  out.translation() = T_world_tool * in_tool;
  return out;
}

void ReflectorRows(const Transform& T_world_tool, const Eigen::Vector3d& in_tool,
                   const Eigen::Ref<const Eigen::MatrixXd>& pose_jacobian, Eigen::Ref<Eigen::MatrixXd> rows) {
  if (pose_jacobian.rows() != 6 || rows.rows() != 3 || rows.cols() != pose_jacobian.cols()) {
    throw std::invalid_argument("ReflectorRows: pose_jacobian must be 6 x n and rows 3 x n");
  }
  const Eigen::Vector3d r = T_world_tool.linear() * in_tool;
  // omega x r = -[r]x omega.
  Eigen::Matrix3d skew;
  skew << 0.0, -r.z(), r.y(), r.z(), 0.0, -r.x(), -r.y(), r.x(), 0.0;
  rows.noalias() = pose_jacobian.topRows<3>() - skew * pose_jacobian.bottomRows<3>();
}

Eigen::Matrix3d ReflectorOffsetRows(const RobotModel& nominal, const Transform& T_world_tool) {
  return T_world_tool.linear() * nominal.T_flange_tool().linear().transpose();
}

}  // namespace robocal

// Parameter priors (priors.h): the groups of a model's error parameters and each one's prior standard deviation.
#include "robocal/core/priors.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace robocal {
namespace {

// +infinity is no prior; everything else must be a positive, finite standard deviation.
bool ValidStd(double value) { return value > 0.0 && !std::isnan(value); }

}  // namespace

bool ParameterPriors::IsValid(std::string* error) const {
  const struct {
    const char* name;
    double value;
  } groups[] = {{"length_mm", length_mm},
                {"angle_rad", angle_rad},
                {"joint_offset_rad", joint_offset_rad},
                {"joint_offset_mm", joint_offset_mm},
                {"base_length_mm", base_length_mm.value_or(1.0)},
                {"base_angle_rad", base_angle_rad.value_or(1.0)},
                {"tool_length_mm", tool_length_mm.value_or(1.0)},
                {"tool_angle_rad", tool_angle_rad.value_or(1.0)}};
  for (const auto& g : groups) {
    if (!ValidStd(g.value)) {
      *error = std::string(g.name) + " must be > 0 (+infinity: no prior)";
      return false;
    }
  }
  for (const auto& [name, value] : parameters) {
    if (!ValidStd(value)) {
      *error = "parameters." + name + " must be > 0 (+infinity: no prior)";
      return false;
    }
  }
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    *error = "scale must be positive and finite";
    return false;
  }
  return true;
}

Eigen::VectorXd PriorStd(const RobotModel& model, const ParameterPriors& priors,
                         const std::vector<Reflector>& reflectors) {
  std::string error;
  if (!priors.IsValid(&error)) throw std::invalid_argument("ParameterPriors: " + error);
  const int n_model = model.num_error_parameters();
  const int n_fit = n_model + 3 * static_cast<int>(reflectors.size());
  const double none = std::numeric_limits<double>::infinity();
  Eigen::VectorXd out = Eigen::VectorXd::Constant(n_fit, none);
  const int sites = model.num_error_sites();
  for (int k = 0; k < model.num_geometric_parameters(); ++k) {
    const int site = k / 6;
    const bool length = RobotModel::IsTranslationParameter(k);
    double sigma = length ? priors.length_mm : priors.angle_rad;
    if (site == 0) {
      sigma = (length ? priors.base_length_mm : priors.base_angle_rad).value_or(sigma);
    } else if (site == sites - 1) {
      sigma = (length ? priors.tool_length_mm : priors.tool_angle_rad).value_or(sigma);
    } else {
      if (model.IsJointOffsetParameter(k)) {
        sigma = model.joint_type(site - 1) == JointType::kRevolute ? priors.joint_offset_rad : priors.joint_offset_mm;
      }
    }
    out[k] = sigma;
  }
  for (const auto& [name, sigma] : priors.parameters) {
    const int index = ParameterIndex(model, reflectors, name);
    if (index < 0) {
      throw std::invalid_argument("ParameterPriors: parameters." + name + ": robot '" + model.name() +
                                  "' has no such error parameter" + (reflectors.empty() ? "" : " or reflector offset"));
    }
    out[index] = sigma;
  }
  return out * priors.scale;
}

Eigen::VectorXd DefaultPriorStd(const RobotModel& model, double scale, const std::vector<Reflector>& reflectors) {
  ParameterPriors priors;
  priors.scale = scale;
  return PriorStd(model, priors, reflectors);
}

}  // namespace robocal

// The calibration the compensation benchmarks run on: `model` with errors of an industrial robot on every site
// (0.2 mm and 3.5e-4 rad per parameter, seeded), its base registered with the base site's errors.
#pragma once

#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"
#include "robocal/core/robot_model.h"

namespace robocal::bench {

inline Calibration IndustrialCalibration(const RobotModel& model) {
  Rng rng(1);
  Eigen::VectorXd errors(model.num_error_parameters());
  for (int k = 0; k < errors.size(); ++k) {
    errors[k] = RobotModel::IsTranslationParameter(k) ? 0.2 * rng.Normal() : 3.5e-4 * rng.Normal();
  }
  return Calibration{.model = model,
                     .errors = errors,
                     .parameters = {},
                     .covariance = {},
                     .T_world_base = model.T_world_base() * ErrorTransform(errors.data()),
                     .T_flange_tool = model.T_flange_tool(),
                     .reflectors = {},
                     .summary = {}};
}

}  // namespace robocal::bench

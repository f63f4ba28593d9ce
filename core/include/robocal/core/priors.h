// Parameter priors: each error parameter's a-priori standard deviation, the expected size of its error, which
// makes a fit a maximum a-posteriori (MAP) estimate under a zero-mean Gaussian prior (docs/identification.md,
// "Parameter priors").
#pragma once

#include <Eigen/Core>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "robocal/core/reflectors.h"
#include "robocal/core/robot_model.h"

namespace robocal {

/// The default prior standard deviations per kind (issue 38): a length 1 mm, an angle 0.1 deg, a joint offset
/// 0.1 deg; the base and tool sites the same. Tenths of a mm and hundredths of a degree are what an industrial
/// robot's geometric errors are (the virtual cell draws 0.2 mm and 0.02 deg); the defaults are a few times wider,
/// so that they hold a parameter the data leave open near zero without pulling on one the data determine.
inline constexpr double kDefaultPriorLengthMm = 1.0;
inline constexpr double kDefaultPriorAngleRad = 0.1 * 3.14159265358979323846 / 180.0;
inline constexpr double kDefaultPriorJointOffsetRad = 0.1 * 3.14159265358979323846 / 180.0;

/// Which prior a fit puts on each of its parameters, by group and by name; PriorStd resolves it against a model.
/// A standard deviation of +infinity is no prior (the parameter is fitted as without priors: its prior row has
/// weight 1 / sigma = 0); zero, negative and NaN are refused (a parameter to hold at zero is one not estimated,
/// IdentificationOptions::parameters). Every value is in the parameter's core unit (mm, rad).
///
/// Groups, each parameter in exactly one (the most specific that applies, in this order):
///   `parameters`     by name (RobotModel::parameter_name, e.g. "joint2.dz", "base.rx", "joint3.compliance", or a
///                    reflector's offset, ParameterName: "reflector.<id>.dx");
///   base, tool       the base and tool sites' translations and rotations (base_length_mm, base_angle_rad,
///                    tool_length_mm, tool_angle_rad), when set;
///   joint offsets    a revolute joint's rotation about its own axis (its site's rz), joint_offset_rad; a prismatic
///                    joint's translation along it (dz), joint_offset_mm;
///   lengths, angles  every other translation (mm) and rotation (rad) of the base, joint and tool sites.
/// Joint terms (compliance, harmonics, map coefficients) and reflector offsets have no prior unless named: their
/// sizes depend on the robot and the nest far more than a geometric error does.
struct ParameterPriors {
  double length_mm = kDefaultPriorLengthMm;
  double angle_rad = kDefaultPriorAngleRad;
  double joint_offset_rad = kDefaultPriorJointOffsetRad;
  double joint_offset_mm = kDefaultPriorLengthMm;
  /// The base and tool sites: no prior unless set. They are frames of the cell rather than errors of the robot
  /// (the tracker's registration; a tool mounted and measured by hand, often millimetres off its nominal length),
  /// and a prior the size of a robot's link errors holds them wrongly: on the IPA UR10 (tool 16 mm off) the default
  /// priors on them raised the cross-validated error from 0.54 to 2.5 mm. A kept parameter that stands in for a
  /// dropped frame parameter (joint6.dz for tool.dz) takes its prior too (WithInheritedPriors).
  std::optional<double> base_length_mm = std::numeric_limits<double>::infinity();
  std::optional<double> base_angle_rad = std::numeric_limits<double>::infinity();
  std::optional<double> tool_length_mm = std::numeric_limits<double>::infinity();
  std::optional<double> tool_angle_rad = std::numeric_limits<double>::infinity();
  std::map<std::string, double> parameters;
  /// Multiplies every standard deviation above, the named ones included (the candidates of priors: auto are
  /// scales of one set of priors). Positive and finite.
  double scale = 1.0;

  /// Every standard deviation > 0 (or +infinity), the scale positive and finite; else false and the field
  /// ("length_mm", "parameters.joint2.dz", ...).
  bool IsValid(std::string* error) const;
};

/// The prior standard deviation of each of a fit's parameters (the fit's index space, reflectors.h: the model's
/// num_error_parameters(), then 3 offsets per reflector), +infinity where there is none. Throws
/// std::invalid_argument for invalid priors or a name in `priors.parameters` that is no parameter of the model or
/// the reflectors (naming it).
Eigen::VectorXd PriorStd(const RobotModel& model, const ParameterPriors& priors,
                         const std::vector<Reflector>& reflectors = {});

/// The default priors (ParameterPriors{}) of `model`'s parameters times `scale` (> 0): PriorStd with scale.
Eigen::VectorXd DefaultPriorStd(const RobotModel& model, double scale = 1.0,
                                const std::vector<Reflector>& reflectors = {});

/// A parameter the prior rather than the data determined (IdentificationSummary::prior_determined): its posterior
/// variance at unit variance factor, C_kk = [(J'WJ + P)^-1]_kk, is above half its prior variance sigma_k^2. For
/// one parameter on its own C = 1 / (I_data + 1 / sigma^2), so this is the data's information below the
/// prior's; with several, I_data is what the data say of it once the others are estimated beside it.
struct PriorDeterminedParameter {
  int index = -1;
  std::string name;
  /// Its prior standard deviation (mm, rad) and the data's share of its information, 1 - C_kk / sigma_k^2 in
  /// [0, 0.5): 0 when the data say nothing of it, 0.5 at the rule's bound.
  double prior_std = 0.0;
  double data_share = 0.0;
};

}  // namespace robocal

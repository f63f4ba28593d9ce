// A calibrated robot written as a Denavit-Hartenberg table (standard or modified), for controllers and tools
// that take a DH table: the table is rebuilt from the calibrated joint axes, and refused where a DH row cannot
// carry the calibration (an axis tilted out of parallel with its neighbour).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/robot_model.h"

namespace robocal {

/// Thrown when the calibrated chain has no usable DH table: which row field would leave its nominal value by more
/// than a calibration can (the implausible-error bounds, 100 mm and 10 degrees), why, and the identified error
/// parameters that cause it.
class DhTableError : public std::runtime_error {
 public:
  DhTableError(std::string field, const std::string& reason, std::vector<std::string> parameters);
  /// The row field, e.g. "joints[2].d_mm".
  const std::string& field() const { return field_; }
  /// The error parameters that tilt the axes apart, largest contribution first (may be empty).
  const std::vector<std::string>& parameters() const { return parameters_; }

 private:
  std::string field_;
  std::vector<std::string> parameters_;
};

/// The spec of `model` with the error parameters `errors` (num_error_parameters, mm / rad; empty: none) folded
/// in, written in `convention` (kStandardDh or kModifiedDh). Its forward kinematics equal
/// ForwardKinematics(model, q, errors) for every q, to round-off. Joint names, types and limits are the model's.
///
/// How (docs/formats.md): every joint axis of the calibrated chain at q = 0 is a line in the tracker frame. The
/// DH frames are put on these lines by the DH rules (z on an axis, x along the common normal of two axes, the
/// origin at its foot), and each row read off consecutive frames. Where the rules leave a choice (parallel or
/// coincident axes, the sign of x, frame 0's x and the last frame), the frame nearest the model's own frame there
/// is taken, so a DH model without errors gets its own table back. The base pose is tracker -> frame 0 (on the
/// first axis), the tool pose the last frame -> the calibrated tool.
///
/// A DH row has no rotation about the axis across the common normal, so two axes that are parallel in the model
/// and tilted out of parallel by the errors put their common normal far away (Hayati's objection to DH):
/// a row whose d or a would move by more than 100 mm, or theta or alpha by more than 10 degrees, from the
/// nominal table's is refused with DhTableError naming the field and the error parameters that tilt the axes.
/// Throws std::invalid_argument for another convention or a wrong size of `errors`.
RobotModelSpec CalibratedDhSpec(const RobotModel& model, const Eigen::VectorXd& errors,
                                GeometryConvention convention);

/// The spec of `model` with `errors` (num_error_parameters, mm / rad) folded in, in the transform convention,
/// which takes any calibrated geometry (parallel axes included): each joint's fixed transform with its site's
/// error, the base site's error folded into the first joint, the tool site's into the tool; base and flange
/// the model's; the joint terms' parameters added to the joint terms the joints hold, the error terms none (the
/// next fit's choice). Its forward kinematics equal ForwardKinematics(model, q, errors, payload) for every q and
/// payload, to round-off; with compliances, to the change the errors make to the gravity torques (its own chain,
/// the calibrated one, gives them: the links' tilt by the errors, some 0.1-2 % of the deflections). Joint names,
/// types, limits and masses are the model's. Throws std::invalid_argument for a wrong size of `errors`.
RobotModelSpec CalibratedTransformSpec(const RobotModel& model, const Eigen::VectorXd& errors);

}  // namespace robocal

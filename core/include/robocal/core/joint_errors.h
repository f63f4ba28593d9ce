// Joint errors beyond geometry: joint compliance under gravity (links and payload) and harmonics of a joint's own
// angle. Both turn a joint by a small angle on top of its command, so the calibrated robot's joints are q + dq(q).
#pragma once

#include <Eigen/Core>
#include <string>

#include "robocal/core/robot_model.h"

namespace robocal {

/// Standard gravity (m/s^2).
inline constexpr double kStandardGravity = 9.80665;

/// The gravity torques tau_i (N*m) about every revolute joint's axis at joints q: the torque gravity exerts about
/// joint i's axis on everything beyond it (the links it and the later joints move, each of JointSpec::mass_kg at
/// JointSpec::com_mm, and `payload` on the flange), by the NOMINAL chain in the base frame, gravity along
/// RobotModelSpec::gravity_base. Positive about +z of the joint; zero for a prismatic joint. The nominal chain is
/// used on purpose: it makes tau independent of the error parameters (the geometric errors move a centre of mass
/// by tenths of a mm, a torque by 1e-4 of itself), so a compliance's Jacobian column is exact.
/// dtau_dq, if not null, receives the n x n derivative d tau_i / d q_j (N*m per rad or per mm).
/// Throws std::invalid_argument if q does not have num_joints values.
Eigen::VectorXd GravityTorques(const RobotModel& model, const Eigen::VectorXd& q, const Payload& payload,
                               Eigen::MatrixXd* dtau_dq = nullptr);

/// The cubic B-spline basis of a map grid (JointMap) at joint value q (rad): returns j, the index of the first of
/// the four coefficients non-zero at q, and their basis values in b[0..3] (they sum to 1); db[0..3], if not null,
/// receives their derivatives per rad, zero beyond the knots, where the map is clamped.
int MapBasis(double first_knot_rad, double knot_spacing_rad, int intervals, double q, double b[4],
             double db[4] = nullptr);
/// A map's value at q (rad) and, if not null, its derivative per rad.
double MapValue(const JointMap& map, double q, double* derivative = nullptr);

/// The factor by which each joint term of `model` (RobotModel::joint_terms(), in order) turns its joint per unit
/// of its parameter at command q: tau_i (N*m) for a compliance (parameter rad per N*m), sin(k q_i) and cos(k q_i)
/// for a harmonic of order k (parameter rad), the basis value B_k for a map coefficient (parameter rad). Empty for
/// a model without joint terms.
/// dfactor_dq, if not null, receives its derivative (terms x num_joints).
Eigen::VectorXd JointTermFactors(const RobotModel& model, const Eigen::VectorXd& q, const Payload& payload,
                                 Eigen::MatrixXd* dfactor_dq = nullptr);

/// The value the robot holds for joint term `term` (JointSpec::compliance_rad_per_nm, harmonics_rad's element for
/// its order and kind, or the coefficient of the held error_map when it has the term's grid, else 0): a fitted
/// parameter of that term is a correction on top of it.
double HeldJointTerm(const RobotModel& model, const JointTermParameter& term);
/// The same element, writable, in a spec's joints (a map term's joint gets a zero map on the model's grid first
/// if it holds none; throws std::invalid_argument if it holds one on another grid).
double& HeldJointTerm(RobotModelSpec* spec, const JointTermParameter& term);

/// The joint deflection dq (rad per joint; zero for prismatic joints) at command q: the joint terms the robot holds
/// (JointSpec::compliance_rad_per_nm, harmonics_rad), plus, for error parameters eps (num_error_parameters, or
/// empty for none), the sum over the model's joint terms of parameter times factor. The robot's joints are
/// q + dq. ddq_dq, if not null, receives d(dq)/dq (n x n).
Eigen::VectorXd JointDeflection(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                                const Payload& payload, Eigen::MatrixXd* ddq_dq = nullptr);

/// What JointDeflection computes from the command alone (q and payload, not eps): the deflection of the joint terms
/// the robot holds and the JointTermFactors of its joint-term parameters. A fit evaluates the same poses at many eps;
/// it prepares each pose once, and the gravity torques are not computed again per evaluation.
struct PreparedDeflection {
  Eigen::VectorXd held;    ///< rad per joint (empty for a robot that does not deflect: RobotModel::deflects())
  Eigen::VectorXd factor;  ///< JointTermFactors (empty for a model without joint-term parameters)
};
PreparedDeflection PrepareDeflection(const RobotModel& model, const Eigen::VectorXd& q, const Payload& payload);

/// JointDeflection(model, q, eps, payload) from PrepareDeflection(model, q, payload): the same dq, by the same
/// operations. Throws std::invalid_argument if eps has neither 0 nor num_error_parameters values.
Eigen::VectorXd JointDeflection(const RobotModel& model, const PreparedDeflection& prepared,
                                const Eigen::VectorXd& eps);

/// The joints of `q` (rad / mm) that lie beyond the knots of an error map `model` fits (its JointMapTerms) or holds
/// (JointSpec::error_map), where the map holds its end value: "joint J at A deg lies beyond its error map's knots
/// (F .. L deg), ..., where the map holds its end value"; empty when none does.
std::string BeyondMapKnots(const RobotModel& model, const Eigen::VectorXd& q);

}  // namespace robocal

// Measurement residuals and the analytic identification and joint Jacobians (twist form).
#include "robocal/core/error_model.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "robocal/core/joint_errors.h"
#include "robocal/core/units.h"

namespace robocal {
namespace {

// Writes the rows of one elementary screw motion into column `col`: a twist with angular part `omega`
// (unit axis for a rotation, zero for a translation) through `point`, and linear part `v`.
// Position row: dp = v + omega x (p_tool - point). Orientation: omega. Axis: t_k . (omega x u).
struct RowWriter {
  MeasurementType type;
  Eigen::Vector3d p_tool;
  Eigen::Vector3d u;
  Eigen::Vector3d t1, t2;

  void Write(const Eigen::Vector3d& omega, const Eigen::Vector3d& point, const Eigen::Vector3d& v,
             Eigen::Ref<Eigen::MatrixXd> jacobian, int col) const {
    jacobian.block<3, 1>(0, col) = v + omega.cross(p_tool - point);
    switch (type) {
      case MeasurementType::kPosition:
        break;
      case MeasurementType::kPositionAxis: {
        const Eigen::Vector3d du = omega.cross(u);
        jacobian(3, col) = t1.dot(du);
        jacobian(4, col) = t2.dot(du);
        break;
      }
      case MeasurementType::kPose:
        jacobian.block<3, 1>(3, col) = omega;
        break;
    }
  }
};

RowWriter MakeWriter(MeasurementType type, const Transform& T_world_tool) {
  RowWriter w{type, T_world_tool.translation(), T_world_tool.linear().col(2), {}, {}};
  if (type == MeasurementType::kPositionAxis) TangentBasis(w.u, &w.t1, &w.t2);
  return w;
}

void CheckJacobianSize(const Eigen::Ref<Eigen::MatrixXd>& jacobian, int rows, int cols, const char* what) {
  if (jacobian.rows() != rows || jacobian.cols() != cols) {
    throw std::invalid_argument(std::string(what) + ": jacobian is " + std::to_string(jacobian.rows()) + "x" +
                                std::to_string(jacobian.cols()) + ", expected " + std::to_string(rows) + "x" +
                                std::to_string(cols));
  }
}

}  // namespace

const char* ToString(MeasurementType type) {
  switch (type) {
    case MeasurementType::kPosition:
      return "position";
    case MeasurementType::kPositionAxis:
      return "position_axis";
    case MeasurementType::kPose:
      return "pose";
  }
  return "?";
}

bool ParseMeasurementType(const std::string& text, MeasurementType* type) {
  for (MeasurementType t : {MeasurementType::kPosition, MeasurementType::kPositionAxis, MeasurementType::kPose}) {
    if (text == ToString(t)) {
      *type = t;
      return true;
    }
  }
  return false;
}

int MeasurementRows(MeasurementType type) {
  switch (type) {
    case MeasurementType::kPosition:
      return 3;
    case MeasurementType::kPositionAxis:
      return 5;
    case MeasurementType::kPose:
      return 6;
  }
  return 0;
}

double TrackerUncertainty::RadialSigmaMm(double distance_mm) const {
  return (radial_um + radial_um_per_m * distance_mm * 1e-3) * 1e-3 / mpe_sigmas;
}

double TrackerUncertainty::TransverseSigmaMm(double distance_mm) const {
  return (transverse_um + transverse_um_per_m * distance_mm * 1e-3) * 1e-3 / mpe_sigmas;
}

double TrackerUncertainty::OrientationSigmaRad() const { return orientation_deg * kRadPerDeg / mpe_sigmas; }

namespace {

// a u u' + b (I - u u') for the beam direction u of `point` (b I at the origin, where there is no beam).
Eigen::Matrix3d AlongAndAcross(const Eigen::Vector3d& point, double a, double b) {
  const double d = point.norm();
  if (!(d > 0.0)) return b * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d u = point / d;
  const Eigen::Matrix3d uu = u * u.transpose();
  return a * uu + b * (Eigen::Matrix3d::Identity() - uu);
}

}  // namespace

Eigen::Matrix3d TrackerUncertainty::PositionCovariance(const Eigen::Vector3d& point_mm) const {
  const double d = point_mm.norm();
  const double r = RadialSigmaMm(d), t = TransverseSigmaMm(d);
  return AlongAndAcross(point_mm, r * r, t * t);
}

Eigen::Matrix3d TrackerUncertainty::PositionSqrt(const Eigen::Vector3d& point_mm) const {
  const double d = point_mm.norm();
  return AlongAndAcross(point_mm, RadialSigmaMm(d), TransverseSigmaMm(d));
}

Eigen::Matrix3d TrackerUncertainty::PositionWhitening(const Eigen::Vector3d& point_mm) const {
  const double d = point_mm.norm();
  return AlongAndAcross(point_mm, 1.0 / RadialSigmaMm(d), 1.0 / TransverseSigmaMm(d));
}

bool TrackerUncertainty::IsValid(std::string* error) const {
  // Bounds that keep every weight and its square finite (1 / (1e-3 um)^2 = 1e12 mm^-2), far beyond any
  // tracker on either side.
  const struct {
    const char* name;
    double value;
    double min, max;
  } fields[] = {{"radial_um", radial_um, kMinTrackerUm, 1000.0},
                {"radial_um_per_m", radial_um_per_m, 0.0, 1000.0},
                {"transverse_um", transverse_um, kMinTrackerUm, 1000.0},
                {"transverse_um_per_m", transverse_um_per_m, 0.0, 1000.0},
                {"orientation_deg", orientation_deg, kMinTrackerOrientationDeg, 90.0},
                {"mpe_sigmas", mpe_sigmas, 0.1, 10.0}};
  for (const auto& f : fields) {
    if (!(f.value >= f.min && f.value <= f.max)) {
      std::ostringstream range;
      range << "tracker." << f.name << " must be in [" << f.min << ", " << f.max << "]";
      *error = range.str();
      return false;
    }
  }
  return true;
}

Eigen::VectorXd MeasurementNoise::RowWeights(MeasurementType type) const {
  Eigen::VectorXd w(MeasurementRows(type));
  double variance = position_mm * position_mm;
  if (tracker) {
    const double r = tracker->RadialSigmaMm(kAssumedTrackerDistanceMm);
    const double t = tracker->TransverseSigmaMm(kAssumedTrackerDistanceMm);
    variance = (r * r + 2.0 * t * t) / 3.0;
  }
  const double repeatability = RepeatabilitySigmaMm();
  w.head<3>().setConstant(
      1.0 / std::sqrt(variance + repeatability * repeatability + model_error_mm * model_error_mm));
  const double t = OrientationSigmaRad();
  w.tail(w.size() - 3).setConstant(1.0 / std::sqrt(t * t + model_error_rad * model_error_rad));
  return w;
}

void MeasurementNoise::Whitening(MeasurementType type, const Eigen::Vector3d& point_mm, Eigen::Ref<Eigen::MatrixXd> w,
                                 int repeatability_visits) const {
  const int rows = MeasurementRows(type);
  if (w.rows() != rows || w.cols() != rows) throw std::invalid_argument("MeasurementNoise::Whitening: wrong size");
  w.setZero();
  // An isotropic variance added to s_r^2 u u' + s_t^2 (I - u u') keeps its form: both sigmas grow.
  const double visits = static_cast<double>(repeatability_visits);
  const double repeatability = RepeatabilitySigmaMm();
  const double shared = visits * (repeatability * repeatability + model_error_mm * model_error_mm);
  if (tracker) {
    const double d = point_mm.norm();
    const double r = tracker->RadialSigmaMm(d), t = tracker->TransverseSigmaMm(d);
    w.topLeftCorner<3, 3>() =
        AlongAndAcross(point_mm, 1.0 / std::sqrt(r * r + shared), 1.0 / std::sqrt(t * t + shared));
  } else {
    w.topLeftCorner<3, 3>().diagonal().setConstant(1.0 / std::sqrt(position_mm * position_mm + shared));
  }
  const double t = OrientationSigmaRad();
  const double orientation = 1.0 / std::sqrt(t * t + visits * model_error_rad * model_error_rad);
  for (int k = 3; k < rows; ++k) w(k, k) = orientation;
}

bool MeasurementNoise::IsValid(std::string* error) const {
  if (!(repeatability_mm >= 0.0 && repeatability_mm <= 10.0)) {
    *error = "noise.repeatability_mm must be in [0, 10]";
    return false;
  }
  if (!(model_error_mm >= 0.0 && model_error_mm <= 100.0)) {
    *error = "noise.model_error_mm must be in [0, 100]";
    return false;
  }
  if (!(model_error_rad >= 0.0 && model_error_rad <= 0.1)) {
    *error = "noise.model_error_rad must be in [0, 0.1]";
    return false;
  }
  if (tracker) return tracker->IsValid(error);
  if (!(position_mm > 0.0) || !std::isfinite(position_mm)) {
    *error = "noise.position_mm must be positive and finite";
    return false;
  }
  if (!(orientation_rad > 0.0) || !std::isfinite(orientation_rad)) {
    *error = "noise.orientation_rad must be positive and finite";
    return false;
  }
  return true;
}

void TangentBasis(const Eigen::Vector3d& u, Eigen::Vector3d* t1, Eigen::Vector3d* t2) {
  // Cross with the world axis least aligned with u: always well conditioned (|u . e| <= 1/sqrt(3)).
  Eigen::Index k = 0;
  u.cwiseAbs().minCoeff(&k);
  *t1 = u.cross(Eigen::Vector3d::Unit(k)).normalized();
  *t2 = u.cross(*t1);
}

void MeasurementResidual(MeasurementType type, const Transform& measured, const Transform& model,
                         Eigen::Ref<Eigen::VectorXd> residual) {
  if (residual.size() != MeasurementRows(type)) throw std::invalid_argument("MeasurementResidual: wrong size");
  residual.head<3>() = measured.translation() - model.translation();
  switch (type) {
    case MeasurementType::kPosition:
      break;
    case MeasurementType::kPositionAxis: {
      const Eigen::Vector3d u_model = model.linear().col(2);
      const Eigen::Vector3d du = measured.linear().col(2) - u_model;
      Eigen::Vector3d t1, t2;
      TangentBasis(u_model, &t1, &t2);
      residual[3] = t1.dot(du);
      residual[4] = t2.dot(du);
      break;
    }
    case MeasurementType::kPose:
      residual.tail<3>() = RotationVector(measured.linear() * model.linear().transpose());
      break;
  }
}

namespace {

// Column `col` of joint i's unit motion at the frames in `ws` (after ForwardKinematics): a rotation about its
// axis, or a translation along it.
void WriteJointColumn(const RobotModel& model, const KinematicsWorkspace& ws, const RowWriter& writer, int i,
                      Eigen::Ref<Eigen::MatrixXd> jacobian, int col) {
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  const Transform& frame = ws.T_world_joint[i];
  const Eigen::Vector3d axis = frame.linear().col(2);
  if (model.joint_type(i) == JointType::kRevolute) {
    writer.Write(axis, frame.translation(), zero, jacobian, col);
  } else {
    writer.Write(zero, zero, axis, jacobian, col);
  }
}

}  // namespace

void IdentificationJacobian(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                            MeasurementType type, KinematicsWorkspace* ws, Eigen::Ref<Eigen::MatrixXd> jacobian,
                            const Payload& payload) {
  IdentificationJacobian(model, q, eps, type, ws, jacobian, PrepareDeflection(model, q, payload));
}

void IdentificationJacobian(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                            MeasurementType type, KinematicsWorkspace* ws, Eigen::Ref<Eigen::MatrixXd> jacobian,
                            const PreparedDeflection& prepared) {
  CheckJacobianSize(jacobian, MeasurementRows(type), model.num_error_parameters(), "IdentificationJacobian");
  const Transform& tool = ForwardKinematics(model, q, eps, ws, prepared);
  const RowWriter writer = MakeWriter(type, tool);
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  const KinematicsWorkspace::SiteErrors* errors = eps.size() != 0 ? &ws->site_errors : nullptr;  // FK's
  for (int s = 0; s < model.num_error_sites(); ++s) {
    // Site s: Trans(d) Rx(rx) Ry(ry) Rz(rz) after frame A. Each parameter is a screw motion about/along an
    // axis of the frame it acts in, so its column is that unit twist carried to the world frame.
    const Transform& a = ws->T_world_site[s];
    const double* delta = eps.size() != 0 ? eps.data() + 6 * s : nullptr;
    const Eigen::Matrix3d r0 = a.linear();
    for (int k = 0; k < 3; ++k) writer.Write(zero, zero, r0.col(k), jacobian, 6 * s + k);
    Eigen::Vector3d point = a.translation();
    Eigen::Matrix3d r1 = r0, r2 = r0;
    if (delta != nullptr) {
      point += r0 * Eigen::Vector3d(delta[0], delta[1], delta[2]);
      r1 = r0 * errors->rx[static_cast<size_t>(s)];
      r2 = r1 * errors->ry[static_cast<size_t>(s)];
    }
    writer.Write(r0.col(0), point, zero, jacobian, 6 * s + 3);
    writer.Write(r1.col(1), point, zero, jacobian, 6 * s + 4);
    writer.Write(r2.col(2), point, zero, jacobian, 6 * s + 5);
  }
  // A joint term turns its joint by (parameter x factor): its column is the joint's motion times the factor
  // (the factor does not depend on the parameters: JointTermFactors).
  const std::vector<JointTermParameter>& terms = model.joint_terms();
  if (terms.empty()) return;
  const int first = model.num_geometric_parameters();
  for (size_t t = 0; t < terms.size(); ++t) {
    const int col = first + static_cast<int>(t);
    const double factor = prepared.factor[static_cast<Eigen::Index>(t)];
    // A map coefficient is zero away from its four intervals: most of a map's columns are.
    if (factor == 0.0) {
      jacobian.col(col).setZero();
      continue;
    }
    WriteJointColumn(model, *ws, writer, terms[t].joint, jacobian, col);
    jacobian.col(col) *= factor;
  }
}

void JointJacobian(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps, MeasurementType type,
                   KinematicsWorkspace* ws, Eigen::Ref<Eigen::MatrixXd> jacobian, const Payload& payload) {
  CheckJacobianSize(jacobian, MeasurementRows(type), model.num_joints(), "JointJacobian");
  const Transform& tool = ForwardKinematics(model, q, eps, ws, payload);
  const RowWriter writer = MakeWriter(type, tool);
  for (int i = 0; i < model.num_joints(); ++i) WriteJointColumn(model, *ws, writer, i, jacobian, i);
  if (!model.deflects()) return;
  // The chain moves with the deflected joints q + dq(q): d/dq = J(q + dq) (I + d(dq)/dq).
  Eigen::MatrixXd ddq_dq;
  JointDeflection(model, q, eps, payload, &ddq_dq);
  const Eigen::MatrixXd at_deflected = jacobian;
  jacobian = at_deflected * (Eigen::MatrixXd::Identity(model.num_joints(), model.num_joints()) + ddq_dq);
}

}  // namespace robocal

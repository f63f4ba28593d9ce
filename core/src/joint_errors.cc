// Gravity torques of the nominal chain and the joint deflections of the compliance and harmonic terms.
#include "robocal/core/joint_errors.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "robocal/core/kinematics.h"
#include "robocal/core/units.h"

namespace robocal {

Eigen::VectorXd GravityTorques(const RobotModel& model, const Eigen::VectorXd& q, const Payload& payload,
                               Eigen::MatrixXd* dtau_dq) {
  const int n = model.num_joints();
  if (q.size() != n) {
    throw std::invalid_argument("GravityTorques: q has " + std::to_string(q.size()) + " values, robot '" +
                                model.name() + "' has " + std::to_string(n) + " joints");
  }
  std::vector<Transform> joint(n);
  Transform flange;
  NominalChainInBase(model, q, joint.data(), &flange);
  // Bodies: link b (b < n, moved by joints 0..b) and the payload (b = n, moved by every joint). Their weights (N)
  // and centres of mass (mm, base frame).
  const Eigen::Vector3d g = kStandardGravity * model.spec().gravity_base;
  std::vector<Eigen::Vector3d> com(n + 1), force(n + 1);
  for (int b = 0; b < n; ++b) {
    const JointSpec& j = model.spec().joints[b];
    const Transform motion = j.type == JointType::kRevolute ? Rotation(RotZ(q[b])) : Translation(0, 0, q[b]);
    com[b] = joint[b] * motion * model.link_frame(b) * j.com_mm;
    force[b] = j.mass_kg * g;
  }
  com[n] = flange * payload.com_mm;
  force[n] = payload.mass_kg * g;
  // Moments are in N*mm; 1e-3 makes them N*m.
  constexpr double kNmPerNmm = 1e-3;
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(n);
  if (dtau_dq != nullptr) dtau_dq->setZero(n, n);
  for (int i = 0; i < n; ++i) {
    if (model.joint_type(i) != JointType::kRevolute) continue;
    const Eigen::Vector3d z = joint[i].linear().col(2);
    const Eigen::Vector3d o = joint[i].translation();
    Eigen::Vector3d moment = Eigen::Vector3d::Zero();
    for (int b = i; b <= n; ++b) moment += (com[b] - o).cross(force[b]);
    tau[i] = kNmPerNmm * z.dot(moment);
    if (dtau_dq == nullptr) continue;
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3d zj = joint[j].linear().col(2);
      const Eigen::Vector3d oj = joint[j].translation();
      double d = 0.0;
      if (model.joint_type(j) == JointType::kRevolute) {
        if (j <= i) {
          // Joint j turns joint i's axis and everything beyond it rigidly: d z = zj x z, d (c - o) = zj x (c - o).
          d = zj.cross(z).dot(moment);
          for (int b = i; b <= n; ++b) d += z.dot(zj.cross(com[b] - o).cross(force[b]));
        } else {
          // Joint j turns only the bodies beyond it, about its own axis.
          for (int b = j; b <= n; ++b) d += z.dot(zj.cross(com[b] - oj).cross(force[b]));
        }
      } else if (j > i) {
        // A prismatic joint beyond i slides the bodies beyond it along its axis; one before i moves joint i's
        // axis and its bodies together (no change).
        for (int b = j; b <= n; ++b) d += z.dot(zj.cross(force[b]));
      }
      (*dtau_dq)(i, j) = kNmPerNmm * d;
    }
  }
  return tau;
}

int MapBasis(double first_knot_rad, double knot_spacing_rad, int intervals, double q, double b[4], double db[4]) {
  const double u = (q - first_knot_rad) / knot_spacing_rad;
  int j = 0;
  double t = 0.0;
  bool inside = false;
  if (u >= intervals) {
    j = intervals - 1;
    t = 1.0;
  } else if (u >= 0.0) {
    j = std::min(static_cast<int>(std::floor(u)), intervals - 1);
    t = u - j;
    inside = true;
  }
  const double s = 1.0 - t, t2 = t * t, t3 = t2 * t;
  b[0] = s * s * s / 6.0;
  b[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
  b[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
  b[3] = t3 / 6.0;
  if (db != nullptr) {
    const double per_rad = inside ? 1.0 / knot_spacing_rad : 0.0;
    db[0] = -0.5 * s * s * per_rad;
    db[1] = (1.5 * t2 - 2.0 * t) * per_rad;
    db[2] = (-1.5 * t2 + t + 0.5) * per_rad;
    db[3] = 0.5 * t2 * per_rad;
  }
  return j;
}

double MapValue(const JointMap& map, double q, double* derivative) {
  if (map.empty()) {
    if (derivative != nullptr) *derivative = 0.0;
    return 0.0;
  }
  double b[4], db[4];
  const int j = MapBasis(map.first_knot_rad, map.knot_spacing_rad, map.intervals(), q, b, db);
  double value = 0.0, slope = 0.0;
  for (int r = 0; r < 4; ++r) {
    value += map.coefficients_rad[static_cast<size_t>(j + r)] * b[r];
    slope += map.coefficients_rad[static_cast<size_t>(j + r)] * db[r];
  }
  if (derivative != nullptr) *derivative = slope;
  return value;
}

Eigen::VectorXd JointTermFactors(const RobotModel& model, const Eigen::VectorXd& q, const Payload& payload,
                                 Eigen::MatrixXd* dfactor_dq) {
  const std::vector<JointTermParameter>& terms = model.joint_terms();
  const int n = model.num_joints();
  Eigen::VectorXd factor(static_cast<Eigen::Index>(terms.size()));
  if (dfactor_dq != nullptr) dfactor_dq->setZero(static_cast<Eigen::Index>(terms.size()), n);
  if (terms.empty()) return factor;
  Eigen::VectorXd tau;
  Eigen::MatrixXd dtau;
  if (model.error_terms().compliance) tau = GravityTorques(model, q, payload, dfactor_dq != nullptr ? &dtau : nullptr);
  // Each mapped joint's four non-zero basis values at q (the rest of its coefficients' factors are zero).
  const JointMapTerms& maps = model.error_terms().maps;
  std::vector<std::array<double, 8>> basis(maps.joints.size());
  std::vector<int> basis_first(maps.joints.size());
  std::vector<int> map_of(static_cast<size_t>(n), -1);
  for (size_t m = 0; m < maps.joints.size(); ++m) {
    const int i = maps.joints[m];
    map_of[static_cast<size_t>(i)] = static_cast<int>(m);
    basis_first[m] = MapBasis(maps.first_knot_rad[m], maps.knot_spacing_rad, maps.intervals[m], q[i], basis[m].data(),
                              basis[m].data() + 4);
  }
  for (size_t t = 0; t < terms.size(); ++t) {
    const JointTermParameter& term = terms[t];
    const int i = term.joint;
    const double k = static_cast<double>(term.order);
    const Eigen::Index row = static_cast<Eigen::Index>(t);
    switch (term.kind) {
      case JointTermParameter::Kind::kCompliance:
        factor[row] = tau[i];
        if (dfactor_dq != nullptr) dfactor_dq->row(row) = dtau.row(i);
        break;
      case JointTermParameter::Kind::kSin:
        factor[row] = std::sin(k * q[i]);
        if (dfactor_dq != nullptr) (*dfactor_dq)(row, i) = k * std::cos(k * q[i]);
        break;
      case JointTermParameter::Kind::kCos:
        factor[row] = std::cos(k * q[i]);
        if (dfactor_dq != nullptr) (*dfactor_dq)(row, i) = -k * std::sin(k * q[i]);
        break;
      case JointTermParameter::Kind::kMap: {
        const size_t m = static_cast<size_t>(map_of[static_cast<size_t>(i)]);
        const int r = term.order - basis_first[m];
        factor[row] = r >= 0 && r < 4 ? basis[m][static_cast<size_t>(r)] : 0.0;
        if (dfactor_dq != nullptr) (*dfactor_dq)(row, i) = r >= 0 && r < 4 ? basis[m][static_cast<size_t>(r) + 4] : 0.0;
        break;
      }
    }
  }
  return factor;
}

namespace {

// Where a joint term's held value sits in its joint: the element of harmonics_rad, or -1 for the compliance.
int HarmonicIndex(const JointTermParameter& term) {
  switch (term.kind) {
    case JointTermParameter::Kind::kSin:
      return 2 * (term.order - 1);
    case JointTermParameter::Kind::kCos:
      return 2 * (term.order - 1) + 1;
    case JointTermParameter::Kind::kCompliance:
    case JointTermParameter::Kind::kMap:
      break;
  }
  return -1;
}

// The grid of a map term's joint in a model's terms: its first knot, spacing and intervals as a JointMap without
// coefficients.
JointMap MapGrid(const JointMapTerms& maps, int joint) {
  for (size_t m = 0; m < maps.joints.size(); ++m) {
    if (maps.joints[m] == joint && m < maps.intervals.size()) {
      return {.first_knot_rad = maps.first_knot_rad[m],
              .knot_spacing_rad = maps.knot_spacing_rad,
              .coefficients_rad = std::vector<double>(static_cast<size_t>(maps.intervals[m] + 3), 0.0)};
    }
  }
  throw std::invalid_argument("joint " + std::to_string(joint + 1) + " has no map term");
}

bool SameGrid(const JointMap& a, const JointMap& b) {
  return a.first_knot_rad == b.first_knot_rad && a.knot_spacing_rad == b.knot_spacing_rad &&
         a.coefficients_rad.size() == b.coefficients_rad.size();
}

}  // namespace

double& HeldJointTerm(RobotModelSpec* spec, const JointTermParameter& term) {
  JointSpec& joint = spec->joints.at(static_cast<size_t>(term.joint));
  if (term.kind == JointTermParameter::Kind::kMap) {
    const JointMap grid = MapGrid(spec->error_terms.maps, term.joint);
    if (joint.error_map.empty()) joint.error_map = grid;
    if (!SameGrid(joint.error_map, grid)) {
      throw std::invalid_argument("joint '" + joint.name + "' holds an error map on another grid than the model's");
    }
    return joint.error_map.coefficients_rad.at(static_cast<size_t>(term.order));
  }
  const int h = HarmonicIndex(term);
  return h < 0 ? joint.compliance_rad_per_nm : joint.harmonics_rad[h];
}

double HeldJointTerm(const RobotModel& model, const JointTermParameter& term) {
  const JointSpec& joint = model.spec().joints.at(static_cast<size_t>(term.joint));
  if (term.kind == JointTermParameter::Kind::kMap) {
    if (joint.error_map.empty() || !SameGrid(joint.error_map, MapGrid(model.error_terms().maps, term.joint)))
      return 0.0;
    return joint.error_map.coefficients_rad.at(static_cast<size_t>(term.order));
  }
  const int h = HarmonicIndex(term);
  return h < 0 ? joint.compliance_rad_per_nm : joint.harmonics_rad[h];
}

namespace {

// The deflection of the joint terms the robot holds (JointSpec::compliance_rad_per_nm, harmonics_rad), added to
// dq and its derivative to ddq_dq (if not null).
void AddFixedDeflection(const RobotModel& model, const Eigen::VectorXd& q, const Payload& payload, Eigen::VectorXd* dq,
                        Eigen::MatrixXd* ddq_dq) {
  const std::vector<JointSpec>& joints = model.spec().joints;
  bool compliance = false;
  for (const JointSpec& j : joints) compliance = compliance || j.compliance_rad_per_nm != 0.0;
  Eigen::VectorXd tau;
  Eigen::MatrixXd dtau;
  if (compliance) tau = GravityTorques(model, q, payload, ddq_dq != nullptr ? &dtau : nullptr);
  for (int i = 0; i < model.num_joints(); ++i) {
    const JointSpec& j = joints[static_cast<size_t>(i)];
    if (j.type != JointType::kRevolute) continue;
    const Eigen::Vector4d& h = j.harmonics_rad;
    const double s1 = std::sin(q[i]), c1 = std::cos(q[i]), s2 = std::sin(2.0 * q[i]), c2 = std::cos(2.0 * q[i]);
    double map_slope = 0.0;
    (*dq)[i] += h[0] * s1 + h[1] * c1 + h[2] * s2 + h[3] * c2 + MapValue(j.error_map, q[i], &map_slope);
    if (j.compliance_rad_per_nm != 0.0) (*dq)[i] += j.compliance_rad_per_nm * tau[i];
    if (ddq_dq == nullptr) continue;
    (*ddq_dq)(i, i) += h[0] * c1 - h[1] * s1 + 2.0 * h[2] * c2 - 2.0 * h[3] * s2 + map_slope;
    if (j.compliance_rad_per_nm != 0.0) ddq_dq->row(i) += j.compliance_rad_per_nm * dtau.row(i);
  }
}

// Whether the joint-term parameters of eps (empty, or num_error_parameters values) add to the deflection; throws on
// a wrong size.
bool HasTermErrors(const RobotModel& model, const Eigen::VectorXd& eps) {
  if (model.joint_terms().empty() || eps.size() == 0) return false;
  if (eps.size() != model.num_error_parameters()) {
    throw std::invalid_argument("JointDeflection: eps has " + std::to_string(eps.size()) + " values, expected " +
                                std::to_string(model.num_error_parameters()) + " or 0");
  }
  return true;
}

}  // namespace

Eigen::VectorXd JointDeflection(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                                const Payload& payload, Eigen::MatrixXd* ddq_dq) {
  const int n = model.num_joints();
  Eigen::VectorXd dq = Eigen::VectorXd::Zero(n);
  if (ddq_dq != nullptr) ddq_dq->setZero(n, n);
  if (model.has_fixed_joint_terms()) AddFixedDeflection(model, q, payload, &dq, ddq_dq);
  if (!HasTermErrors(model, eps)) return dq;
  const std::vector<JointTermParameter>& terms = model.joint_terms();
  Eigen::MatrixXd dfactor;
  const Eigen::VectorXd factor = JointTermFactors(model, q, payload, ddq_dq != nullptr ? &dfactor : nullptr);
  const int first = model.num_geometric_parameters();
  for (size_t t = 0; t < terms.size(); ++t) {
    const double value = eps[first + static_cast<Eigen::Index>(t)];
    const Eigen::Index row = static_cast<Eigen::Index>(t);
    dq[terms[t].joint] += value * factor[row];
    if (ddq_dq != nullptr) ddq_dq->row(terms[t].joint) += value * dfactor.row(row);
  }
  return dq;
}

PreparedDeflection PrepareDeflection(const RobotModel& model, const Eigen::VectorXd& q, const Payload& payload) {
  PreparedDeflection out;
  // A robot that does not deflect has nothing to prepare (a planner asks for the identification Jacobian of every
  // candidate pose).
  if (!model.deflects()) return out;
  out.held = Eigen::VectorXd::Zero(model.num_joints());
  if (model.has_fixed_joint_terms()) AddFixedDeflection(model, q, payload, &out.held, nullptr);
  if (!model.joint_terms().empty()) out.factor = JointTermFactors(model, q, payload);
  return out;
}

Eigen::VectorXd JointDeflection(const RobotModel& model, const PreparedDeflection& prepared,
                                const Eigen::VectorXd& eps) {
  if (!model.deflects()) return Eigen::VectorXd::Zero(model.num_joints());
  Eigen::VectorXd dq = prepared.held;
  if (!HasTermErrors(model, eps)) return dq;
  const std::vector<JointTermParameter>& terms = model.joint_terms();
  const int first = model.num_geometric_parameters();
  for (size_t t = 0; t < terms.size(); ++t) {
    dq[terms[t].joint] += eps[first + static_cast<Eigen::Index>(t)] * prepared.factor[static_cast<Eigen::Index>(t)];
  }
  return dq;
}

std::string BeyondMapKnots(const RobotModel& model, const Eigen::VectorXd& q) {
  if (q.size() != model.num_joints()) return "";
  std::ostringstream out;
  out << std::setprecision(4);
  const JointMapTerms& maps = model.error_terms().maps;
  for (int i = 0; i < model.num_joints(); ++i) {
    double first = 0.0, last = 0.0;
    bool mapped = false;
    for (std::size_t m = 0; m < maps.joints.size() && m < maps.intervals.size(); ++m) {
      if (maps.joints[m] != i) continue;
      first = maps.first_knot_rad[m];
      last = first + maps.intervals[m] * maps.knot_spacing_rad;
      mapped = true;
    }
    const JointMap& held = model.spec().joints[static_cast<std::size_t>(i)].error_map;
    if (!mapped && !held.empty()) {
      first = held.first_knot_rad;
      last = held.last_knot_rad();
      mapped = true;
    }
    if (!mapped || (q[i] >= first - 1e-12 && q[i] <= last + 1e-12)) continue;
    out << (out.tellp() > 0 ? ", " : "") << "joint " << model.joint_name(i) << " at " << q[i] * kDegPerRad
        << " deg lies beyond its error map's knots (" << first * kDegPerRad << " .. " << last * kDegPerRad << " deg)";
  }
  return out.tellp() > 0 ? out.str() + ", where the map holds its end value" : "";
}

}  // namespace robocal

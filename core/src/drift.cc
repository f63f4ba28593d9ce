// Drift checks (drift.h, docs/drift.md): the residual level against the calibration's own scatter, and the one
// parameter that best explains the residuals, both in the metric of the calibration's own residuals.
#include "robocal/core/drift.h"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "robocal/core/compensation.h"
#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"
#include "robocal/core/reflectors.h"

namespace robocal {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Directions closer than this (|cos| above it) in the residuals' space are one explanation to the check's poses.
constexpr double kSameDirectionCos = 0.995;

// The frames-only fit (no model error estimated, no outliers excluded: a check judges every shot it has).
Calibration Register(const RobotModel& model, const std::vector<Measurement>& shots, const DriftCheckOptions& options,
                     const std::vector<int>& frames) {
  IdentificationOptions o;
  o.measurement_type = options.measurement_type;
  o.noise = options.noise;
  o.identifiability.noise = options.noise;
  o.parameters = frames;
  std::sort(o.parameters.begin(), o.parameters.end());
  o.register_base = true;
  o.estimate_model_error = false;
  o.reject_outliers = false;
  return Identify(model, shots, o);
}

// Rows (residual or Jacobian columns) of one measurement turned from the world frame into the base frame: the
// position rows and the orientation rows are vectors; a position-axis measurement's axis rows are components in
// the axis's own tangent plane, which no frame turns.
void ToBase(MeasurementType type, const Eigen::Matrix3d& R_base_world, Eigen::Ref<Eigen::MatrixXd> rows) {
  rows.topRows<3>() = R_base_world * rows.topRows<3>();
  if (type == MeasurementType::kPose) rows.bottomRows<3>() = R_base_world * rows.bottomRows<3>();
}

}  // namespace

std::vector<int> FrameParameters(const RobotModel& model, MeasurementType type, bool reflectors) {
  // The base site's six and the tool site's translations; its rotations where the measurements see them: a point
  // sees none, a point and an axis the two that tilt the axis, a pose (or nests about the tool) all three.
  const int tool = 6 * (model.num_error_sites() - 1);
  std::vector<int> out = {0, 1, 2, 3, 4, 5, tool, tool + 1, tool + 2};
  const int rotations = reflectors || type == MeasurementType::kPose ? 3
                        : type == MeasurementType::kPositionAxis      ? 2
                                                                       : 0;
  for (int k = 0; k < rotations; ++k) out.push_back(tool + 3 + k);
  return out;
}

bool DriftCheckOptions::IsValid(std::string* error) const {
  if (!(false_alarm_rate > 0.0 && false_alarm_rate < 0.5)) {
    *error = "false_alarm_rate must be in (0, 0.5)";
    return false;
  }
  if (reference.size() < static_cast<std::size_t>(2 * MeasurementRows(measurement_type))) {
    *error = "reference: the calibration's shots are needed (at least twice the rows of a measurement)";
    return false;
  }
  if (!IsValidRigidTransform(reference_T_world_base, 1e-6)) {
    *error = "reference_T_world_base is not a rigid transform";
    return false;
  }
  if (!(null_correction >= 1.0) || !std::isfinite(null_correction) || null_draws < 100) {
    *error = "null_correction must be finite and >= 1, null_draws >= 100";
    return false;
  }
  std::string noise_error;
  if (!noise.IsValid(&noise_error)) {
    *error = "noise: " + noise_error;
    return false;
  }
  return true;
}

namespace {

// Residual rows and Jacobian rows of shots against (model, errors), in the base frame, scaled by the row weights:
// one block of `rows` per shot.
struct ShotRows {
  std::vector<Eigen::VectorXd> residual;
  std::vector<Eigen::MatrixXd> jacobian;
  double position_sum = 0.0;
};
ShotRows BaseRows(const RobotModel& model, const Eigen::VectorXd& errors, const std::vector<Measurement>& shots,
                  MeasurementType type, const Eigen::VectorXd& w) {
  const int rows = MeasurementRows(type);
  const Eigen::Matrix3d R_base_world = model.T_world_base().linear().transpose();
  KinematicsWorkspace ws(model);
  ShotRows out;
  Eigen::MatrixXd block(rows, 1 + model.num_error_parameters());
  Eigen::VectorXd one(rows);
  for (const Measurement& m : shots) {
    IdentificationJacobian(model, m.joints, errors, type, &ws, block.rightCols(model.num_error_parameters()),
                           m.payload);
    MeasurementResidual(type, m.T_world_tool, ws.T_world_tool, one);
    out.position_sum += one.head<3>().squaredNorm();
    block.col(0) = one;
    ToBase(type, R_base_world, block);
    block = w.asDiagonal() * block;
    out.residual.push_back(block.col(0));
    out.jacobian.push_back(block.rightCols(model.num_error_parameters()));
  }
  return out;
}

// One set's statistics in the metric `whiten`: the residual level per degree of freedom, and each candidate's score
// test beside the frames (drop, change, std, its unit direction).
struct SetTests {
  double level = 0.0;
  Eigen::VectorXd drop, change, std;
  Eigen::MatrixXd directions;
};
SetTests Tests(const Eigen::VectorXd& r_in, const Eigen::MatrixXd& J, const std::vector<int>& frames,
               const std::vector<int>& candidates, int dof, bool directions) {
  Eigen::VectorXd r = r_in;
  Eigen::MatrixXd G(J.rows(), static_cast<int>(candidates.size()));
  for (std::size_t k = 0; k < candidates.size(); ++k) G.col(static_cast<int>(k)) = J.col(candidates[k]);
  // What the registration's parameters take up (one Gauss-Newton step of them in this metric) is not the check's.
  if (!frames.empty()) {
    Eigen::MatrixXd F(J.rows(), static_cast<int>(frames.size()));
    for (std::size_t k = 0; k < frames.size(); ++k) F.col(static_cast<int>(k)) = J.col(frames[k]);
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(F);
    const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(J.rows(), qr.rank());
    r -= Q * (Q.transpose() * r);
    G -= Q * (Q.transpose() * G);
  }
  SetTests t;
  t.level = r.squaredNorm() / dof;
  const Eigen::VectorXd nn = G.colwise().squaredNorm().transpose();
  const Eigen::VectorXd score = G.transpose() * r;
  t.drop = Eigen::VectorXd::Zero(nn.size());
  t.change = t.std = Eigen::VectorXd::Constant(nn.size(), kNaN);
  for (Eigen::Index k = 0; k < nn.size(); ++k) {
    if (!(nn[k] > 0.0)) continue;
    t.drop[k] = score[k] * score[k] / nn[k];
    t.change[k] = score[k] / nn[k];
    t.std[k] = 1.0 / std::sqrt(nn[k]);
  }
  if (directions) t.directions = G * (nn.array() > 0.0).select(nn.cwiseSqrt().cwiseInverse(), 0.0).asDiagonal();
  return t;
}

double Quantile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size()))) - 1)];
}

// A shot of the wrong joint count or a non-finite joint, in the check or the reference: std::invalid_argument.
void CheckDriftShots(const RobotModel& model, const std::vector<Measurement>& shots, const DriftCheckOptions& options) {
  for (const std::vector<Measurement>* list : {&shots, &options.reference}) {
    for (const Measurement& m : *list) {
      if (m.joints.size() != model.num_joints() || !m.joints.allFinite()) {
        throw std::invalid_argument("CheckDrift: a shot of the wrong joint count or a non-finite joint");
      }
    }
  }
}

// The reference's rows, whitened (and inflated), and the whitening.
struct DriftReference {
  ShotRows rows;
  Eigen::MatrixXd whiten;
};

// The reference: the calibration's own shots against the robot at the calibration's base. Their residuals'
// covariance is the metric (its inverse square root whitens every row below); scaled by the in-sample correction
// they stand for a new pose's.
DriftReference WhitenedDriftReference(const RobotModel& model, const DriftCheckOptions& options,
                                      const Eigen::VectorXd& w) {
  const MeasurementType type = options.measurement_type;
  const int rows = MeasurementRows(type);
  RobotModelSpec reference_spec = model.spec();
  reference_spec.T_world_base = options.reference_T_world_base;
  const RobotModel reference_model = RobotModel::Build(reference_spec);
  ShotRows reference =
      BaseRows(reference_model, Eigen::VectorXd::Zero(model.num_error_parameters()), options.reference, type, w);
  const std::size_t n_reference = reference.residual.size();
  Eigen::MatrixXd c0 = Eigen::MatrixXd::Zero(rows, rows);
  for (const Eigen::VectorXd& z : reference.residual) c0 += z * z.transpose() / static_cast<double>(n_reference);
  c0.diagonal().array() += 1e-12 * c0.diagonal().maxCoeff();
  const Eigen::MatrixXd whiten = Eigen::LLT<Eigen::MatrixXd>(c0).matrixL().solve(Eigen::MatrixXd::Identity(rows, rows));
  const double inflate = std::sqrt(options.null_correction);
  for (std::size_t i = 0; i < n_reference; ++i) {
    reference.residual[i] = inflate * (whiten * reference.residual[i]);
    reference.jacobian[i] = whiten * reference.jacobian[i];
  }
  return {std::move(reference), whiten};
}

// The check's residuals and Jacobian, whitened and stacked shot by shot.
struct DriftStack {
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
};
DriftStack StackWhitened(const ShotRows& check, const Eigen::MatrixXd& whiten, int num_parameters) {
  const int rows = static_cast<int>(whiten.rows());
  const int shots = static_cast<int>(check.residual.size());
  DriftStack out{Eigen::VectorXd(rows * shots), Eigen::MatrixXd(rows * shots, num_parameters)};
  for (int i = 0; i < shots; ++i) {
    out.r.segment(rows * i, rows) = whiten * check.residual[static_cast<std::size_t>(i)];
    out.J.middleRows(rows * i, rows) = whiten * check.jacobian[static_cast<std::size_t>(i)];
  }
  return out;
}

// The candidates: every geometric parameter the registration does not estimate, joint offsets first (unless the
// options name them); std::invalid_argument for one that is no parameter.
std::vector<int> DriftCandidates(const RobotModel& model, const DriftCheckOptions& options,
                                 const std::vector<int>& frames) {
  std::vector<int> candidates = options.candidates;
  if (candidates.empty()) {
    std::vector<int> offsets, others;
    for (int k = 0; k < model.num_geometric_parameters(); ++k) {
      if (std::find(frames.begin(), frames.end(), k) != frames.end()) continue;
      (model.IsJointOffsetParameter(k) ? offsets : others).push_back(k);
    }
    candidates = offsets;
    candidates.insert(candidates.end(), others.begin(), others.end());
  }
  for (int c : candidates) {
    if (c < 0 || c >= model.num_error_parameters()) {
      throw std::invalid_argument("CheckDrift: candidate " + std::to_string(c) + " is no parameter");
    }
  }
  return candidates;
}

// Shots of too few distinct poses leave frame parameters undetermined: what is said then ("" when determined).
std::string UndeterminedFrames(const Eigen::MatrixXd& J, const std::vector<int>& frames) {
  if (frames.empty()) return "";
  Eigen::MatrixXd F(J.rows(), static_cast<int>(frames.size()));
  for (std::size_t k = 0; k < frames.size(); ++k) F.col(static_cast<int>(k)) = J.col(frames[k]);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(F);
  qr.setThreshold(1e-9);
  if (qr.rank() >= static_cast<Eigen::Index>(frames.size())) return "";
  return "the shots do not determine the frames (" + std::to_string(frames.size() - qr.rank()) +
         " of their parameters left free): measure more distinct poses";
}

// Of the candidates tested, those the frames take up whole, or the check's poses do not see, are none: dropped with
// their figures.
void DropUnseenCandidates(const Eigen::MatrixXd& J, std::vector<int>* candidates, SetTests* tests) {
  std::vector<int> kept;
  std::vector<Eigen::Index> columns;
  for (std::size_t k = 0; k < candidates->size(); ++k) {
    const Eigen::Index c = static_cast<Eigen::Index>(k);
    if (std::isfinite(tests->std[c]) &&
        1.0 / (tests->std[c] * tests->std[c]) > 1e-10 * J.col((*candidates)[k]).squaredNorm()) {
      kept.push_back((*candidates)[k]);
      columns.push_back(c);
    }
  }
  *candidates = std::move(kept);
  tests->drop = tests->drop(columns).eval();
  tests->change = tests->change(columns).eval();
  tests->std = tests->std(columns).eval();
  tests->directions = tests->directions(Eigen::all, columns).eval();
}

// The null distributions' draws: each drawn set's residual level and largest drop, and how many levels reach the
// check's statistic.
struct DriftNullDraws {
  std::vector<double> levels, drops;
  int level_above = 0;
};

// Both tests' null distributions by a paired bootstrap: sets of as many of the calibration's own shots, each with
// its residual and its Jacobian, so that the robot's unmodelled error comes with the directions it takes at its
// poses (a joint's gear error looks like an offset of that joint pose by pose), its tails and its share between
// the axes. The check's poses are taken to be spread like the calibration's. `check` gives the set's size, its
// degrees of freedom and its statistic.
DriftNullDraws DrawDriftNull(const ShotRows& reference, const std::vector<int>& frames,
                             const std::vector<int>& candidates, const DriftCheck& check,
                             const DriftCheckOptions& options) {
  const int rows = MeasurementRows(options.measurement_type);
  const int n_rows = rows * check.num_measurements;
  const std::size_t n_reference = reference.residual.size();
  Rng rng(options.seed);
  DriftNullDraws out;
  out.levels.resize(static_cast<std::size_t>(options.null_draws));
  out.drops.resize(out.levels.size());
  Eigen::VectorXd z(n_rows);
  Eigen::MatrixXd Jz(n_rows, reference.jacobian.front().cols());
  for (std::size_t d = 0; d < out.levels.size(); ++d) {
    for (int i = 0; i < check.num_measurements; ++i) {
      const std::size_t k = rng.Index(n_reference);
      z.segment(rows * i, rows) = reference.residual[k];
      Jz.middleRows(rows * i, rows) = reference.jacobian[k];
    }
    const SetTests null = Tests(z, Jz, frames, candidates, check.dof, false);
    out.levels[d] = null.level;
    if (out.levels[d] >= check.statistic) ++out.level_above;
    out.drops[d] = candidates.empty() ? 0.0 : null.drop.maxCoeff();
  }
  return out;
}

// The suspects of a check that drifted, largest drop first; of parameters the poses cannot tell apart, one, a joint
// offset named first. Beyond the drop threshold when a parameter drifted, else the three largest.
std::vector<DriftSuspect> DriftSuspects(const RobotModel& model, const std::vector<int>& candidates,
                                        const SetTests& tests, double drop_threshold, bool parameter_drifted) {
  std::vector<DriftSuspect> suspects;
  std::vector<std::size_t> order(candidates.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return tests.drop[static_cast<Eigen::Index>(a)] > tests.drop[static_cast<Eigen::Index>(b)];
  });
  std::vector<bool> used(candidates.size(), false);
  for (std::size_t oi = 0; oi < order.size(); ++oi) {
    const std::size_t a = order[oi];
    if (used[a]) continue;
    const double drop = tests.drop[static_cast<Eigen::Index>(a)];
    if (!(drop > drop_threshold) && (parameter_drifted || suspects.size() >= 3)) break;
    std::vector<std::size_t> group = {a};
    for (std::size_t ob = oi + 1; ob < order.size(); ++ob) {
      const std::size_t b = order[ob];
      if (!used[b] && std::abs(tests.directions.col(static_cast<Eigen::Index>(a))
                                   .dot(tests.directions.col(static_cast<Eigen::Index>(b)))) > kSameDirectionCos) {
        group.push_back(b);
      }
    }
    std::size_t lead = a;
    for (std::size_t k : group) {
      used[k] = true;
      if (model.IsJointOffsetParameter(candidates[k]) && !model.IsJointOffsetParameter(candidates[lead])) lead = k;
    }
    DriftSuspect s;
    s.index = candidates[lead];
    s.name = ParameterName(model, {}, s.index);
    s.change = tests.change[static_cast<Eigen::Index>(lead)];
    s.std = tests.std[static_cast<Eigen::Index>(lead)];
    s.chi2_drop = tests.drop[static_cast<Eigen::Index>(lead)];
    for (std::size_t k : group) {
      if (k != lead) s.equivalent.push_back(ParameterName(model, {}, candidates[k]));
    }
    suspects.push_back(std::move(s));
  }
  return suspects;
}

std::string DriftMessage(const DriftCheck& out) {
  std::ostringstream m;
  m.precision(3);
  m << (out.drifted ? "drifted" : "holds") << ": residual level " << out.statistic << " (threshold " << out.threshold
    << ")";
  if (out.num_candidates > 0) {
    m << ", largest single-parameter drop " << out.largest_drop << " (threshold " << out.drop_threshold << ", "
      << out.num_candidates << " candidates)";
  }
  if (!out.suspects.empty()) m << "; best explained by " << out.suspects.front().name;
  return m.str();
}

}  // namespace

DriftCheck CheckDrift(const RobotModel& model, const std::vector<Measurement>& shots,
                      const DriftCheckOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("CheckDrift: " + error);
  CheckDriftShots(model, shots, options);
  const MeasurementType type = options.measurement_type;
  const int rows = MeasurementRows(type);
  DriftCheck out;
  out.num_measurements = static_cast<int>(shots.size());
  const std::vector<int> frames = options.register_frames ? FrameParameters(model, type) : std::vector<int>{};
  const int n_rows = rows * out.num_measurements;
  out.dof = n_rows - static_cast<int>(frames.size());
  out.expected_rms_position_mm = std::sqrt(3.0) / options.noise.RowWeights(MeasurementType::kPosition)[0];
  if (out.dof < 3) {
    out.statistic = out.threshold = kNaN;
    out.message = std::to_string(out.num_measurements) + " shots give " + std::to_string(n_rows) +
                  " rows: too few for " + std::to_string(frames.size()) + " frame parameters and a check";
    return out;
  }
  const Eigen::VectorXd w = options.noise.RowWeights(type);
  const DriftReference reference = WhitenedDriftReference(model, options, w);

  // The check: the registration (or the frames as kept), the residuals and the Jacobian there.
  const Calibration registered =
      options.register_frames ? Register(model, shots, options, frames) : NominalCalibration(model);
  if (options.register_frames && registered.summary.termination == Termination::kFailure) {
    out.statistic = out.threshold = kNaN;
    out.message = "the shots do not register the frames: " + registered.summary.message;
    return out;
  }
  out.T_world_base = registered.T_world_base;
  out.T_flange_tool = registered.T_flange_tool;
  const ShotRows check = BaseRows(registered.model, registered.errors, shots, type, w);
  out.rms_position_mm = std::sqrt(check.position_sum / out.num_measurements);
  const DriftStack stack = StackWhitened(check, reference.whiten, model.num_error_parameters());
  const Eigen::VectorXd& r = stack.r;
  const Eigen::MatrixXd& J = stack.J;

  std::vector<int> candidates = DriftCandidates(model, options, frames);
  const std::string undetermined = UndeterminedFrames(J, frames);
  if (!undetermined.empty()) {
    out.statistic = out.threshold = kNaN;
    out.message = undetermined;
    return out;
  }
  // One pass over every candidate (each column's test is its own), then those the frames take up whole, or the
  // check's poses do not see, are none: dropped with their figures.
  SetTests tests = Tests(r, J, frames, candidates, out.dof, true);
  DropUnseenCandidates(J, &candidates, &tests);
  out.statistic = tests.level;
  out.num_candidates = static_cast<int>(candidates.size());
  out.largest_drop = candidates.empty() ? 0.0 : tests.drop.maxCoeff();

  const DriftNullDraws null = DrawDriftNull(reference.rows, frames, candidates, out, options);
  const double level = 1.0 - options.false_alarm_rate / 2.0;
  out.threshold = Quantile(null.levels, level);
  out.p_value = static_cast<double>(null.level_above) / static_cast<double>(null.levels.size());
  out.drop_threshold = candidates.empty() ? 0.0 : Quantile(null.drops, level);
  const bool level_drifted = out.statistic > out.threshold;
  const bool parameter_drifted = !candidates.empty() && out.largest_drop > out.drop_threshold;
  out.drifted = level_drifted || parameter_drifted;
  if (out.drifted) out.suspects = DriftSuspects(model, candidates, tests, out.drop_threshold, parameter_drifted);
  out.message = DriftMessage(out);
  return out;
}

}  // namespace robocal

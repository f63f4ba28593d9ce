// Identification: the parameters a fit estimates, one weighted fit over them (IdentifyOnce: registration, the
// least-squares problem, Levenberg-Marquardt, covariance, residual statistics), and the fit's reports. The robust
// fit around it is robust_fit.cc; what the parts share is identification_internal.h.
#include "robocal/core/identification.h"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

#include "identification_internal.h"
#include "robocal/core/column_scaling.h"
#include "robocal/core/fit_diagnostics.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/units.h"

namespace robocal {

using namespace identification_detail;

bool IdentificationOptions::IsValid(std::string* error) const {
  if (!noise.IsValid(error)) return false;
  for (size_t k = 0; k < parameters.size(); ++k) {
    if (parameters[k] < 0 || (k > 0 && parameters[k] <= parameters[k - 1])) {
      *error = "parameters must be non-negative and strictly ascending (parameters[" + std::to_string(k) + "])";
      return false;
    }
  }
  std::string sub;
  // Checked even with explicit parameters: the rank test of the data uses identifiability.rank_tolerance.
  if (!identifiability.IsValid(&sub)) {
    *error = "identifiability." + sub;
    return false;
  }
  const struct {
    const char* name;
    double value;
  } tolerances[] = {{"function_tolerance", function_tolerance},
                    {"gradient_tolerance", gradient_tolerance},
                    {"parameter_tolerance", parameter_tolerance}};
  for (const auto& t : tolerances) {
    if (!(t.value >= 0.0) || !std::isfinite(t.value)) {
      *error = std::string(t.name) + " must be finite and >= 0";
      return false;
    }
  }
  if (priors && !priors->IsValid(&sub)) {
    *error = "priors." + sub;
    return false;
  }
  if (!ValidateReflectors(reflectors, error)) return false;
  if (!reflectors.empty() && measurement_type != MeasurementType::kPosition) {
    *error = "reflectors need position measurements (a 6-DoF probe measures the tool's orientation itself)";
    return false;
  }
  if (!(outlier_probability > 0.0 && outlier_probability <= 0.1)) {
    *error = "outlier_probability must be in (0, 0.1]";
    return false;
  }
  if (max_iterations < 1 || max_iterations > 100000) {
    *error = "max_iterations must be in [1, 100000]";
    return false;
  }
  return true;
}

namespace identification_detail {

// A joint term whose column at the measured configurations keeps less than this fraction of its norm outside
// the span of the other chosen columns is not observed by the data: its standard deviation would be over 100
// times that of a parameter observed on its own, and its value whatever the noise makes it (then extrapolated to
// other poses). A harmonic of order 1 of a joint measured over only a degree or two, or one of order 2 over a few
// degrees, stays below it; so does a compliance whose gravity torque hardly changes between the measured poses.
constexpr double kJointTermObservedFraction = 1e-2;

// The joint terms (compliance, harmonics) the measurements observe: structural identifiability (random
// configurations, no payload) cannot know which payloads and configurations a campaign holds, so their
// columns are tested again at the measured poses. `parameters` (ascending) loses the unobserved ones, which join
// `dropped`.
void DropUnobservedJointTerms(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                              const IdentificationOptions& options, std::vector<int>* parameters,
                              std::vector<DroppedParameter>* dropped) {
  const int first_term = nominal.num_geometric_parameters();
  const int n_all = nominal.num_error_parameters();
  if (nominal.joint_terms().empty()) return;
  const ShotGroups groups(measurements);
  // With reflector nests the fit sees the tool's whole pose through them (nests off the tool point see it turn):
  // the pose rows then stand for them, as in the fit's own Jacobian before it is carried to each nest.
  const MeasurementType type = options.reflectors.empty() ? options.measurement_type : MeasurementType::kPose;
  const int rows = MeasurementRows(type);
  const Eigen::VectorXd weights = options.noise.RowWeights(type);
  const Eigen::Index num_rows = static_cast<Eigen::Index>(groups.poses.size()) * rows;
  // Map coefficients are left to the fit's rank test: their penalty determines what the data leave open.
  std::vector<int> model_columns;
  for (int j : *parameters) {
    if (j < n_all && (j < first_term || nominal.joint_terms()[static_cast<size_t>(j - first_term)].kind !=
                                            JointTermParameter::Kind::kMap)) {
      model_columns.push_back(j);
    }
  }
  Eigen::MatrixXd full(rows, n_all);
  Eigen::MatrixXd a(num_rows, static_cast<Eigen::Index>(model_columns.size()));
  KinematicsWorkspace ws(nominal);
  for (size_t p = 0; p < groups.poses.size(); ++p) {
    IdentificationJacobian(nominal, groups.poses[p], Eigen::VectorXd(), type, &ws, full, groups.payloads[p]);
    for (size_t c = 0; c < model_columns.size(); ++c) {
      a.block(static_cast<Eigen::Index>(p) * rows, static_cast<Eigen::Index>(c), rows, 1) =
          weights.cwiseProduct(full.col(model_columns[c]));
    }
  }
  std::vector<int> geometric, terms;
  for (size_t c = 0; c < model_columns.size(); ++c) (model_columns[c] < first_term ? geometric : terms).push_back(c);
  if (terms.empty()) return;
  // Unit columns; the terms' parts outside the geometric span, then a pivoted QR among those parts.
  for (Eigen::Index c = 0; c < a.cols(); ++c) {
    const double norm = a.col(c).norm();
    if (norm > 0.0) a.col(c) /= norm;
  }
  Eigen::MatrixXd g(num_rows, static_cast<Eigen::Index>(geometric.size()));
  for (size_t c = 0; c < geometric.size(); ++c) g.col(static_cast<Eigen::Index>(c)) = a.col(geometric[c]);
  Eigen::MatrixXd t(num_rows, static_cast<Eigen::Index>(terms.size()));
  for (size_t c = 0; c < terms.size(); ++c) t.col(static_cast<Eigen::Index>(c)) = a.col(terms[c]);
  if (g.cols() > 0) {
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(g);
    const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(num_rows, g.cols());
    t -= q * (q.transpose() * t);
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> pivoted(t);
  const Eigen::MatrixXd r = pivoted.matrixR().template triangularView<Eigen::Upper>();
  std::vector<int> unobserved;
  for (Eigen::Index k = 0; k < std::min(r.rows(), r.cols()); ++k) {
    if (std::abs(r(k, k)) < kJointTermObservedFraction) {
      for (Eigen::Index rest = k; rest < r.cols(); ++rest) {
        unobserved.push_back(model_columns[terms[pivoted.colsPermutation().indices()[rest]]]);
      }
      break;
    }
  }
  if (r.rows() < r.cols()) {
    for (Eigen::Index rest = r.rows(); rest < r.cols(); ++rest)
      unobserved.push_back(model_columns[terms[pivoted.colsPermutation().indices()[rest]]]);
  }
  if (unobserved.empty()) return;
  std::sort(unobserved.begin(), unobserved.end());
  unobserved.erase(std::unique(unobserved.begin(), unobserved.end()), unobserved.end());
  for (int j : unobserved) {
    const JointTermParameter& term = nominal.joint_terms()[static_cast<size_t>(j - first_term)];
    dropped->push_back(
        {j, nominal.parameter_name(j),
         term.kind == JointTermParameter::Kind::kCompliance
             ? "not observed by these measurements: its gravity torques move the tool as the other parameters do "
               "(measure under a second payload, or at more varied arm postures)"
             : "not observed by these measurements: its effect is that of the other parameters (measure the joint "
               "over more of its range)"});
    parameters->erase(std::find(parameters->begin(), parameters->end(), j));
  }
}

namespace {

// The parameters a request named (IdentificationOptions::parameters, in the fit's index space of n_fit): every other
// one dropped as "not requested".
ParameterSelection RequestedParameterSelection(const RobotModel& nominal, const IdentificationOptions& options,
                                               int n_fit) {
  ParameterSelection out;
  out.parameters = options.parameters;
  for (int k = 0, next = 0; k < n_fit; ++k) {
    if (next < static_cast<int>(out.parameters.size()) && out.parameters[next] == k)
      ++next;
    else
      out.dropped.push_back({k, ParameterName(nominal, options.reflectors, k), "not requested"});
  }
  return out;
}

// What a selection with reflector nests says of itself (empty: nothing). Held nests (none free) on one line leave
// the tool's turn about that line unobserved; free nests take over the tool point's parameters. `probe` is the
// model the identifiability probe saw (n_probe parameters of the model's n_all), `any_nest` whether a nest has shots.
std::string ReflectorNestsNote(const RobotModel& probe, const IdentificationOptions& options,
                               const ParameterSelection& selection, int n_probe, int n_all, bool free_nests,
                               bool any_nest) {
  if (!free_nests && any_nest) {
    // Held nests on one line (two nests, or three in a row) leave the tool's turn about that line unobserved:
    // fewer of the model's parameters than pose measurements would identify.
    IdentifiabilityOptions pose_options = options.identifiability;
    const IdentifiabilitySummary pose = FindIdentifiableParameters(probe, MeasurementType::kPose, pose_options);
    const auto model_kept =
        std::count_if(selection.parameters.begin(), selection.parameters.end(), [&](int j) { return j < n_probe; });
    if (pose.termination != Termination::kFailure && model_kept < static_cast<long>(pose.identifiable.size())) {
      return "the reflector nests do not observe the tool's full orientation (" + std::to_string(model_kept) +
             " parameters against " + std::to_string(pose.identifiable.size()) +
             " from pose measurements): nests on one line leave the turn about it open, and a tool point off "
             "that line is not calibrated (three nests not on one line observe it)";
    }
  }
  if (!free_nests) return "";
  // The parameters the nests' offsets took over (FindIdentifiableParameters' gauge): they stay nominal.
  std::string held;
  for (const DroppedParameter& d : selection.dropped) {
    if (d.index < n_all && d.reason.find("reflector.") != std::string::npos)
      held += (held.empty() ? "" : ", ") + d.name;
  }
  return "free reflector nests locate themselves, not the tool point: " +
         (held.empty() ? std::string("nothing") : held) +
         " stay nominal (hold the nests at measured positions to calibrate the tool point)";
}

}  // namespace

ParameterSelection SelectParameters(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                                    const IdentificationOptions& options) {
  ParameterSelection out;
  if (nominal.error_terms().compliance && !nominal.has_masses()) {
    out.failure = "model.compliance: robot '" + nominal.name() +
                  "' has no link masses (set joints[].mass_kg and com_mm, or import a URDF with <inertial> "
                  "elements): its gravity torques are unknown";
    return out;
  }
  const int n_all = nominal.num_error_parameters();
  const int num_reflectors = static_cast<int>(options.reflectors.size());
  // The fit's index space: the model's parameters, then 3 offset errors per reflector.
  const int n_fit = n_all + 3 * num_reflectors;
  const auto name = [&](int index) { return ParameterName(nominal, options.reflectors, index); };
  if (!options.parameters.empty()) return RequestedParameterSelection(nominal, options, n_fit);
  // A nest without shots has nothing to say: the identifiability probe leaves it out (its rows would be
  // information the data do not hold) and its offset is dropped by name.
  std::vector<char> measured(num_reflectors, 0);
  for (const Measurement& m : measurements) {
    if (m.reflector >= 0 && m.reflector < num_reflectors) measured[m.reflector] = 1;
  }
  IdentifiabilityOptions identifiability = options.identifiability;
  // The probe draws configurations over the joints' whole ranges; a map lives on the range its poses cover, and its
  // coefficients are chosen as a whole below. The probe sees the model without them.
  const bool maps = !nominal.error_terms().maps.empty();
  JointErrorTerms without_maps = nominal.error_terms();
  without_maps.maps = {};
  const RobotModel probe = maps ? nominal.WithErrorTerms(without_maps) : nominal;
  const int n_probe = probe.num_error_parameters();
  std::vector<int> original;  // probe reflector -> the fit's reflector
  bool free_nests = false;
  for (int k = 0; k < num_reflectors; ++k) {
    if (!measured[k]) continue;
    identifiability.reflectors.push_back(options.reflectors[k]);
    original.push_back(k);
    free_nests = free_nests || !options.reflectors[k].fixed;
  }
  const IdentifiabilitySummary id = FindIdentifiableParameters(probe, options.measurement_type, identifiability);
  if (id.termination == Termination::kFailure) {
    out.failure = "identifiability: " + id.message;
    return out;
  }
  out.termination = id.termination;
  const auto fit_index = [&](int j) {
    return j < n_probe ? j : n_all + 3 * original[(j - n_probe) / 3] + (j - n_probe) % 3;
  };
  for (int j : id.identifiable) out.parameters.push_back(fit_index(j));
  for (DroppedParameter d : id.dropped) {
    d.index = fit_index(d.index);
    if (d.alias >= 0) d.alias = fit_index(d.alias);
    out.dropped.push_back(std::move(d));
  }
  // Every coefficient of every map (their constant, the joint's offset, is held by the constraint rows: Problem).
  if (maps) {
    for (int j = n_probe; j < n_all; ++j) out.parameters.push_back(j);
  }
  for (int k = 0; k < num_reflectors; ++k) {
    if (measured[k]) continue;
    for (int axis = 0; axis < 3; ++axis) {
      const int j = n_all + 3 * k + axis;
      out.dropped.push_back({j, name(j),
                             options.reflectors[k].fixed
                                 ? "held at its given position (fixed reflector)"
                                 : "reflector '" + options.reflectors[k].id + "' has no measurements"});
    }
  }
  std::sort(out.parameters.begin(), out.parameters.end());
  DropUnobservedJointTerms(nominal, measurements, options, &out.parameters, &out.dropped);
  std::sort(out.dropped.begin(), out.dropped.end(),
            [](const DroppedParameter& a, const DroppedParameter& b) { return a.index < b.index; });
  out.note = ReflectorNestsNote(probe, options, out, n_probe, n_all, free_nests, !original.empty());
  return out;
}

namespace {

// The steps of one fit (IdentifyOnce): check, register, rank test, solve, judge. Each returns the reason the fit
// fails ("" to go on) and writes what it finds into the calibration or its summary.

// Check, part one: every shot well formed. Throws std::invalid_argument for joint vectors of the wrong size (a
// caller's error, not the data's).
std::string CheckShots(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                       const IdentificationOptions& options) {
  const MeasurementType type = options.measurement_type;
  const int num_reflectors = static_cast<int>(options.reflectors.size());
  for (size_t i = 0; i < measurements.size(); ++i) {
    if (measurements[i].joints.size() != nominal.num_joints()) {
      throw std::invalid_argument("Identify: measurements[" + std::to_string(i) + "].joints has " +
                                  std::to_string(measurements[i].joints.size()) + " values, robot '" + nominal.name() +
                                  "' has " + std::to_string(nominal.num_joints()) + " joints");
    }
  }
  if (measurements.empty()) return "no measurements";
  for (size_t i = 0; i < measurements.size(); ++i) {
    const std::string problem = CheckMeasurement(measurements[i], type);
    if (!problem.empty()) return "measurements[" + std::to_string(i) + "]: " + problem;
    const int reflector = measurements[i].reflector;
    if (num_reflectors == 0 && reflector != -1) {
      return "measurements[" + std::to_string(i) + "]: names reflector " + std::to_string(reflector) +
             " but the fit has no reflectors";
    }
    if (num_reflectors > 0 && (reflector < 0 || reflector >= num_reflectors)) {
      return "measurements[" + std::to_string(i) + "]: reflector " + std::to_string(reflector) + " is not one of the " +
             std::to_string(num_reflectors) + " reflectors (0.." + std::to_string(num_reflectors - 1) + ")";
    }
  }
  return "";
}

// Check, part two: more rows from distinct poses than parameters (with equality the fit interpolates the pose
// means and only the scatter of repeated shots would be left to estimate sigma_hat from).
std::string CheckRedundancy(MeasurementType type, const ShotGroups& groups, const IdentificationSummary* s) {
  const int rows = MeasurementRows(type);
  const int num_groups = static_cast<int>(groups.groups.size());
  if (rows * num_groups <= s->num_parameters) {
    std::ostringstream msg;
    msg << "too few distinct poses: " << s->num_poses << " distinct joint configuration(s) among "
        << s->num_measurements << " measurements give " << rows * num_groups << " independent " << ToString(type)
        << " rows for " << s->num_parameters << " parameters; need at least " << s->num_parameters / rows + 1
        << " distinct poses";
    return msg.str();
  }
  return "";
}

// Register: the tracker -> base frame from the nominal tool (or reflector) positions onto the measured ones, each
// under its shot's payload (a robot holding compliances sags under it). `model` is the nominal robot so placed.
std::string RegisterBase(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                         const std::vector<Eigen::Vector3d>& nominal_in_tool, RobotModel* model) {
  std::vector<Eigen::Vector3d> from, to;
  from.reserve(measurements.size());
  to.reserve(measurements.size());
  KinematicsWorkspace ws(nominal);
  for (const Measurement& m : measurements) {
    const Transform& tool = ForwardKinematics(nominal, m.joints, Eigen::VectorXd(), &ws, m.payload);
    from.push_back(m.reflector < 0 ? tool.translation() : tool * nominal_in_tool.at(m.reflector));
    to.push_back(m.T_world_tool.translation());
  }
  Transform T;
  try {
    T = RegisterPoints(from, to);
  } catch (const std::invalid_argument&) {
    return "degenerate configurations: the tool positions are collinear or coincident, so the tracker -> base "
           "frame cannot be registered";
  }
  RobotModelSpec spec = nominal.spec();
  spec.T_world_base = T * nominal.T_world_base();
  *model = RobotModel::Build(spec);
  return "";
}

// Rank test on the scaled Jacobian at the start (the solver's: the nominal model, or the solution a refit starts
// from, whose Jacobian is as good a witness of the configurations' rank): degenerate configurations fail here,
// with the parameters they cannot determine named, instead of producing a meaningless fit. The normal equations'
// Cholesky factor decides first; the pivoted QR (seconds at hundreds of columns) only names what is undetermined.
// Writes the cost at the nominal model (initial_cost).
std::string RankTest(Problem* problem, const std::vector<int>& parameters, const IdentificationOptions& options,
                     const std::function<std::string(int)>& name, const FitStart& start, IdentificationSummary* s) {
  const Eigen::MatrixXd& j = start.jacobian;
  if (start.x.isZero(0.0)) {
    s->initial_cost = 0.5 * start.residual.squaredNorm();
  } else {
    Eigen::VectorXd r;
    problem->Evaluate(Eigen::VectorXd::Zero(s->num_parameters), &r, nullptr);
    s->initial_cost = 0.5 * r.squaredNorm();
  }
  if (!std::isfinite(s->initial_cost) || !std::isfinite(start.residual.squaredNorm()) || !AllFinite(j)) {
    return "non-finite residuals at the start";
  }
  const bool many = s->num_parameters > kDenseParameterLimit;
  const double tolerance = many ? std::max(options.identifiability.rank_tolerance, kNormalRankTolerance)
                                : options.identifiability.rank_tolerance;
  // A well-conditioned normal matrix proves full rank at the cost of J'J and a Cholesky; only the rest needs the
  // pivoted QR (which names the undetermined parameters). With few parameters the QR's own test is the rule, so the
  // normal matrix must pass with a margin: its Cholesky's reciprocal condition estimate (of the 1-norm, within a
  // factor n of the 2-norm's) above (10 tolerance)^2, and never below the normal equations' own limit.
  if (FullRankByNormal(j, many ? tolerance : std::max(10.0 * tolerance, kNormalRankTolerance))) return "";
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(j * UnitColumnFactorsOf(j).asDiagonal());
  const int rank = PivotRank(qr.matrixQR().diagonal().cwiseAbs(), tolerance);
  if (rank >= s->num_parameters) return "";
  std::ostringstream msg;
  msg << "degenerate configurations: rank-deficient Jacobian, the " << s->num_poses << " poses determine only " << rank
      << " of " << s->num_parameters << " parameters (undetermined:";
  const auto& perm = qr.colsPermutation().indices();
  for (int k = rank; k < std::min(s->num_parameters, rank + 4); ++k) msg << " " << name(parameters[perm[k]]);
  msg << (s->num_parameters - rank > 4 ? " ...)" : ")");
  return msg.str();
}

// The parameters the prior rather than the data determined (PriorDeterminedParameter): the posterior variance at
// unit variance factor, `inverse` = (J'WJ + P)^-1, above half the prior variance. Judged before the covariance is
// scaled by sigma_hat^2: whether the data or the prior hold a parameter is a matter of their information, not of
// how well the noise model's scale was guessed. The data's share 1 - C_kk / sigma_k^2 is I_data / (I_data + I_prior)
// for a parameter on its own, so the bound is the data's information equal to the prior's.
void JudgePriors(const Problem& problem, const Eigen::MatrixXd& inverse, const std::vector<int>& parameters,
                 const std::function<std::string(int)>& name, IdentificationSummary* s) {
  const Eigen::VectorXd& prior = problem.prior_std();
  for (Eigen::Index k = 0; k < prior.size(); ++k) {
    if (!std::isfinite(prior[k])) continue;
    ++s->num_priors;
    const double prior_variance = prior[k] * prior[k];
    if (inverse(k, k) > 0.5 * prior_variance) {
      const int index = parameters[static_cast<size_t>(k)];
      s->prior_determined.push_back(
          {index, name(index), prior[k], std::clamp(1.0 - inverse(k, k) / prior_variance, 0.0, 1.0)});
    }
  }
}

// Solve: Levenberg-Marquardt from `x0`, then the covariance and condition number from the column-scaled Jacobian
// (the rank test of the start, on the singular values at the solution: the covariance needs every one). With the
// maps' penalty rows or the priors' rows it is the covariance of the penalised (MAP) estimate, the posterior
// (J'WJ + P)^-1 times sigma_hat^2 (the penalty as a prior), and sigma_hat takes
// the measurements' rows over their redundancy: the rows less the effective parameters (a penalised coefficient
// counts less than one). Writes the parameters, errors, frames and residual statistics into `cal`, and with
// `at_solution` the linearisation at the solution (SolutionLinearisation).
std::string Solve(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                  const IdentificationOptions& options, const std::vector<int>& parameters,
                  const std::function<std::string(int)>& name, FitStart start, Problem* problem, RobotModel* model,
                  LmResult* lm, Calibration* cal, SolutionLinearisation* at_solution) {
  IdentificationSummary& s = cal->summary;
  *lm = LevenbergMarquardt(problem, options, std::move(start));
  s.iterations = lm->iterations;
  if (lm->termination == Termination::kFailure || !lm->x.allFinite()) return "optimisation failed: " + lm->reason;
  const Eigen::VectorXd errors = problem->FullErrors(lm->x);
  s.final_cost = 0.5 * lm->residual.squaredNorm();
  Eigen::VectorXd sv;
  const bool by_normal = lm->jacobian.cols() > kDenseParameterLimit && lm->normal.rows() == lm->jacobian.cols();
  const double tolerance = options.identifiability.rank_tolerance;
  if (!(by_normal ? ScaledCovarianceOfNormal(lm->normal, 1.0, tolerance, &sv, &cal->covariance)
                  : ScaledCovariance(lm->jacobian, 1.0, tolerance, &sv, &cal->covariance))) {
    return "degenerate configurations: rank-deficient Jacobian at the solution";
  }
  if (at_solution != nullptr) {
    if (!by_normal) at_solution->inverse_information = cal->covariance;
    if (problem->TakeJacobianAt(lm->x, &at_solution->prediction, &at_solution->group_jacobian)) at_solution->x = lm->x;
  }
  s.effective_parameters = EffectiveParameters(cal->covariance, problem->penalty_normal());
  const double dof = s.num_residuals - s.effective_parameters;
  s.sigma_hat = std::sqrt(lm->residual.head(problem->num_measurement_rows()).squaredNorm() / dof);
  JudgePriors(*problem, cal->covariance, parameters, name, &s);
  cal->covariance *= s.sigma_hat * s.sigma_hat;
  s.condition_number = sv[0] / sv[sv.size() - 1];
  s.singular_values = sv;
  for (int k = 0; k < s.num_parameters; ++k) {
    cal->parameters.push_back({parameters[k], name(parameters[k]), lm->x[k], std::sqrt(cal->covariance(k, k))});
  }
  const Eigen::VectorXd reflector_errors = problem->ReflectorErrors(lm->x);
  s.after = ComputeResidualStatistics(*model, errors, measurements, options.measurement_type, options.noise,
                                      ReflectorsInTool(nominal, options.reflectors, reflector_errors));
  for (size_t k = 0; k < options.reflectors.size(); ++k) {
    cal->reflectors[k].position_mm += reflector_errors.segment<3>(3 * static_cast<Eigen::Index>(k));
  }
  cal->T_world_base = model->T_world_base() * ErrorTransform(errors.data());
  cal->T_flange_tool = model->T_flange_tool() * ErrorTransform(errors.data() + 6 * (model->num_error_sites() - 1));
  cal->errors = errors;
  cal->model = std::move(*model);  // the problem, which refers to it, is done
  return "";
}

// Judge, part one: parameters no robot has. Geometric errors are tenths of a mm and hundredths of a degree; a fit
// that needs metres or tens of degrees matched the shots with a wrong nominal geometry (a tool, a reflector
// position, a table typed wrong). A joint term: a compliance beyond kImplausibleComplianceRadPerNm is no robot
// joint, a harmonic beyond kImplausibleHarmonicRad no gear; the data then hold too little of its effect to say what
// it is (a term nearly constant over the measured poses, fitted to the noise), and it extrapolates wildly. Judged
// on the joint's whole term: what the robot holds (a calibration registered as a robot) and the fitted correction
// on top. Returns the first three implausible geometric errors and their count; the joint terms go to the summary.
std::string ImplausibleErrors(const RobotModel& nominal, const std::vector<IdentifiedParameter>& parameters, int* count,
                              std::vector<std::string>* joint_terms) {
  std::string implausible;
  *count = 0;
  for (const IdentifiedParameter& p : parameters) {
    const bool mm = IsTranslationName(p.name);
    if (p.index >= nominal.num_geometric_parameters() && p.index < nominal.num_error_parameters()) {
      const bool compliance = nominal.parameter_unit(p.index) == ParameterUnit::kRadPerNm;
      const double held = HeldJointTerm(nominal, nominal.joint_terms()[p.index - nominal.num_geometric_parameters()]);
      if (std::abs(held + p.value) > (compliance ? kImplausibleComplianceRadPerNm : kImplausibleHarmonicRad)) {
        std::ostringstream one;
        one << std::setprecision(4) << p.name << " " << (held + p.value) * kDegPerRad
            << (compliance ? " deg/(N*m)" : " deg");
        if (held != 0.0) one << " (held " << held * kDegPerRad << " + fitted " << p.value * kDegPerRad << ")";
        joint_terms->push_back(one.str());
      }
      continue;
    }
    if (std::abs(p.value) > (mm ? kImplausibleErrorMm : kImplausibleErrorRad) && ++*count <= 3) {
      std::ostringstream one;
      one << std::setprecision(4) << p.name << " " << (mm ? p.value : p.value * kDegPerRad) << (mm ? " mm" : " deg");
      implausible += (implausible.empty() ? "" : ", ") + one.str();
    }
  }
  return implausible;
}

// Judge: the termination and the message from the solver's end, the identifiable set's clarity, the selection's
// note and the implausible parameters (each of those degrades a converged fit).
void Judge(const RobotModel& nominal, const ParameterSelection& selection, const LmResult& lm, Calibration* cal) {
  IdentificationSummary& s = cal->summary;
  std::ostringstream msg;
  msg << lm.reason;
  s.termination = lm.termination;
  s.cancelled = lm.cancelled;
  if (lm.termination == Termination::kConvergence && selection.termination == Termination::kDegraded) {
    s.termination = Termination::kDegraded;
    msg << "; the identifiable set was unclear (see FindIdentifiableParameters)";
  }
  if (!selection.note.empty()) msg << "; " << selection.note;
  int count = 0;
  const std::string implausible = ImplausibleErrors(nominal, cal->parameters, &count, &s.implausible_joint_terms);
  if (count > 0) {
    if (s.termination == Termination::kConvergence) s.termination = Termination::kDegraded;
    msg << "; implausible geometric errors (" << implausible << (count > 3 ? ", ..." : "")
        << "): the nominal geometry, the tool or a reflector position is likely wrong";
  }
  if (!s.implausible_joint_terms.empty()) {
    if (s.termination == Termination::kConvergence) s.termination = Termination::kDegraded;
    msg << "; implausible joint terms (";
    for (size_t k = 0; k < s.implausible_joint_terms.size(); ++k)
      msg << (k ? ", " : "") << s.implausible_joint_terms[k];
    msg << "): the measured poses hardly vary what drives them (a payload, the arm's posture, the joint's angle); "
           "fit a simpler model or measure more varied poses";
  }
  s.message = msg.str();
}

}  // namespace

Calibration IdentifyOnce(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                         const IdentificationOptions& options, const ParameterSelection& selection,
                         const Eigen::VectorXd* x0, SolutionLinearisation* at_solution) {
  if (at_solution != nullptr) *at_solution = SolutionLinearisation();
  const Clock::time_point start = Clock::now();
  const MeasurementType type = options.measurement_type;
  const auto name = [&](int index) { return ParameterName(nominal, options.reflectors, index); };
  Calibration cal = NominalCalibration(nominal);
  cal.reflectors = options.reflectors;
  IdentificationSummary& s = cal.summary;
  s.measurement_type = type;
  s.model = nominal.error_terms();
  s.num_measurements = static_cast<int>(measurements.size());
  s.num_residuals = MeasurementRows(type) * s.num_measurements;
  s.scaling = DescribeScaling(options.noise);
  const auto ended = [&](const std::string& failure) {
    if (!failure.empty()) {
      s.termination = Termination::kFailure;
      s.message = failure;
      if (at_solution != nullptr) *at_solution = SolutionLinearisation();
    }
    s.seconds = Seconds(start);
    return cal;
  };
  std::string failure = CheckShots(nominal, measurements, options);
  if (failure.empty()) failure = selection.failure;  // which parameters to estimate
  if (!failure.empty()) return ended(failure);
  s.dropped = selection.dropped;
  s.num_parameters = static_cast<int>(selection.parameters.size());
  // Distinct poses (and reflectors) bound the information; repeated shots only average the noise.
  const ShotGroups groups(measurements);
  s.num_poses = static_cast<int>(groups.poses.size());
  if (!(failure = CheckRedundancy(type, groups, &s)).empty()) return ended(failure);
  // Each reflector's nominal point in the tool frame (empty without reflectors).
  const std::vector<Eigen::Vector3d> nominal_in_tool = ReflectorsInTool(nominal, options.reflectors, Eigen::VectorXd());
  RobotModel model = nominal;
  if (options.register_base && !(failure = RegisterBase(nominal, measurements, nominal_in_tool, &model)).empty()) {
    return ended(failure);
  }
  Problem problem(model, measurements, groups, options, selection.parameters);
  s.before = ComputeResidualStatistics(model, Eigen::VectorXd(), measurements, type, options.noise, nominal_in_tool);
  FitStart fit_start = EvaluateStart(&problem, x0);
  if (!(failure = RankTest(&problem, selection.parameters, options, name, fit_start, &s)).empty()) {
    return ended(failure);
  }
  LmResult lm;
  failure = Solve(nominal, measurements, options, selection.parameters, name, std::move(fit_start), &problem, &model,
                  &lm, &cal, at_solution);
  if (!failure.empty()) return ended(failure);
  Judge(nominal, selection, lm, &cal);
  return ended("");
}

}  // namespace identification_detail

RobotModel WithTermsFor(const RobotModel& robot, const JointErrorTerms& terms,
                        const std::vector<Measurement>& measurements) {
  if (terms.maps.empty()) return robot.WithErrorTerms(terms);
  JointErrorTerms resolved = terms;
  JointMapTerms& maps = resolved.maps;
  maps.first_knot_rad.assign(maps.joints.size(), 0.0);
  maps.intervals.assign(maps.joints.size(), 1);
  const int n = robot.num_joints();
  const double h = maps.knot_spacing_rad;
  // Out-of-range joints and spacings: let Build name them (a placeholder grid meanwhile).
  bool valid = h >= kMinMapKnotSpacingRad * (1 - 1e-12) && h <= kMaxMapKnotSpacingRad * (1 + 1e-12);
  for (int i : maps.joints) valid = valid && i >= 0 && i < n;
  if (!valid || measurements.empty()) return robot.WithErrorTerms(resolved);
  for (size_t m = 0; m < maps.joints.size(); ++m) {
    const int i = maps.joints[m];
    const JointMap& held = robot.spec().joints[static_cast<size_t>(i)].error_map;
    if (!held.empty() && std::abs(held.knot_spacing_rad - h) <= 1e-12 * h) {
      maps.first_knot_rad[m] = held.first_knot_rad;
      maps.intervals[m] = held.intervals();
      continue;
    }
    double lo = measurements.front().joints[i], hi = lo;
    for (const Measurement& ms : measurements) {
      if (ms.joints.size() != n) continue;
      lo = std::min(lo, ms.joints[i]);
      hi = std::max(hi, ms.joints[i]);
    }
    const int intervals = std::clamp(static_cast<int>(std::ceil((hi - lo) / h - 1e-9)), 1, kMaxMapIntervals);
    maps.intervals[m] = intervals;
    maps.first_knot_rad[m] = 0.5 * (lo + hi) - 0.5 * intervals * h;
  }
  return robot.WithErrorTerms(resolved);
}

std::string IdentificationSummary::BriefReport() const {
  std::ostringstream out;
  out << "Identification (" << ToString(measurement_type) << "): " << ToString(termination) << ", " << message;
  if (termination == Termination::kFailure) return out.str();
  out << "; " << num_parameters << " parameters from " << num_poses << " poses (" << num_measurements
      << " measurements";
  if (!outliers.empty()) out << ", " << outliers.size() << " outlier(s) excluded";
  out << "), rms position " << std::setprecision(4) << before.rms_position_mm << " -> " << after.rms_position_mm
      << " mm, sigma_hat " << sigma_hat << ", cond " << condition_number << ", " << iterations << " iterations, "
      << std::setprecision(3) << seconds << " s";
  return out.str();
}

std::string IdentificationSummary::FullReport(const Calibration* estimates) const {
  std::ostringstream out;
  out << BriefReport() << "\n";
  out << "  measurements: " << num_measurements << " (" << num_poses << " distinct poses), residual rows "
      << num_residuals << ", parameters " << num_parameters << "\n";
  out << std::setprecision(4);
  const auto stats = [&](const char* label, const ResidualStatistics& r) {
    out << "  " << label << ": position rms " << r.rms_position_mm << " mm, max " << r.max_position_mm << " mm";
    if (measurement_type != MeasurementType::kPosition) {
      out << "; angle rms " << r.rms_orientation_rad << " rad, max " << r.max_orientation_rad << " rad";
    }
    out << "; weighted rms " << r.rms_weighted << "\n";
  };
  stats("before", before);
  stats("after ", after);
  out << "  cost " << initial_cost << " -> " << final_cost << ", sigma_hat " << sigma_hat << ", iterations "
      << iterations << "\n";
  out << "  condition number " << condition_number << " (" << scaling << ")\n";
  // Printed as position (mm) and roll, pitch, yaw (rad): what cell software that knows nothing of the error
  // model takes over.
  const auto frame = [&](const char* label, const Transform& t) {
    const Eigen::Vector3d p = t.translation(), rpy = RpyFromRotation(t.linear());
    out << "  " << label << ": xyz " << std::setprecision(10) << p.x() << " " << p.y() << " " << p.z() << " mm, rpy "
        << std::setprecision(8) << rpy.x() << " " << rpy.y() << " " << rpy.z() << " rad\n";
  };
  if (estimates != nullptr) {
    frame("T_world_base ", estimates->T_world_base);
    frame("T_flange_tool", estimates->T_flange_tool);
  }
  const std::vector<IdentifiedParameter> none;
  const std::vector<IdentifiedParameter>& parameters = estimates != nullptr ? estimates->parameters : none;
  if (!parameters.empty()) {
    out << "  " << std::left << std::setw(12) << "parameter" << std::right << std::setw(14) << "value" << std::setw(14)
        << "std"
        << "  units\n";
    for (const IdentifiedParameter& p : parameters) {
      const bool mm = IsTranslationName(p.name);
      const bool compliance = p.name.size() > 11 && p.name.compare(p.name.size() - 11, 11, ".compliance") == 0;
      out << "  " << std::left << std::setw(12) << p.name << std::right << std::setw(14) << std::setprecision(6)
          << p.value << std::setw(14) << p.std << "  "
          << (mm           ? "mm"
              : compliance ? "rad/(N*m)"
                           : "rad")
          << "\n";
    }
  }
  if (rejection_rounds > 0) {
    out << "  robust fit: " << rejection_rounds << " round(s), scale " << std::setprecision(4) << robust_scale
        << ", threshold " << outlier_threshold << " sigma, " << outliers.size() << " outlier(s)";
    for (const OutlierMeasurement& o : outliers) {
      out << (&o == &outliers.front() ? ": " : ", ") << "#" << o.measurement << " (" << o.normalized_residual << ")";
    }
    out << "\n";
  }
  out << "  model: " << model.Describe() << "\n";
  for (size_t k = 0; k < model_candidates.size(); ++k) {
    const ModelCandidate& c = model_candidates[k];
    out << "    " << (static_cast<int>(k) == model_chosen ? "* " : "  ") << std::left << std::setw(28)
        << c.terms.Describe() << std::right << std::setw(5) << c.num_parameters << " parameters";
    if (c.failed_folds > 0) {
      out << ", " << c.failed_folds << " of " << model_folds << " folds failed: " << c.note << "\n";
    } else {
      out << ", held-out mean " << std::setprecision(4) << c.cv_mean_mm << " +- " << c.cv_standard_error_mm
          << " mm, RMS " << c.cv_rms_mm << " mm\n";
    }
  }
  if (num_priors > 0) {
    out << "  priors: " << num_priors << " of " << num_parameters << " parameters, effective parameters "
        << std::setprecision(4) << effective_parameters << "; determined by the prior rather than the data ("
        << prior_determined.size() << ")";
    for (const PriorDeterminedParameter& p : prior_determined) {
      out << (&p == &prior_determined.front() ? ": " : ", ") << p.name << " (data share " << std::setprecision(2)
          << p.data_share << ")";
    }
    out << "\n";
  }
  for (size_t k = 0; k < prior_candidates.size(); ++k) {
    const PriorScaleCandidate& c = prior_candidates[k];
    out << "    " << (static_cast<int>(k) == prior_chosen ? "* " : "  ") << "priors ";
    if (std::isfinite(c.scale)) {
      out << "x " << std::left << std::setw(8) << c.scale << std::right;
    } else {
      out << std::left << std::setw(10) << "none" << std::right;
    }
    if (c.failed_folds > 0) {
      out << c.failed_folds << " of " << prior_folds << " folds failed: " << c.note << "\n";
    } else {
      out << "held-out mean " << std::setprecision(4) << c.cv_mean_mm << " +- " << c.cv_standard_error_mm << " mm, RMS "
          << c.cv_rms_mm << " mm\n";
    }
  }
  out << "  dropped (" << dropped.size() << "):\n";
  for (const DroppedParameter& d : dropped) out << "    " << d.name << ": " << d.reason << "\n";
  return out.str();
}

}  // namespace robocal

// The compensation study: random joint commands, Cartesian targets on named branches, and a smooth path, per
// robot, on a calibration with random errors of a given size.
#include "robocal/core/compensation_study.h"

#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "robocal/core/arm_kinematics.h"
#include "robocal/core/compensation.h"
#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/units.h"

namespace robocal {
namespace {


// The robot the study calibrates: 3 m from the tracker and turned, as a registered robot would be.
RobotModel StudyRobot(const std::string& name) {
  RobotModelSpec spec = name == "ur10_mdh" ? Ur10LikeMdhSpec() : PresetSpec(name);
  spec.T_world_base = TransformFromXyzRpy({3000.0, -1200.0, 500.0}, {0.1, -0.05, 2.0});
  return RobotModel::Build(spec);
}

Calibration StudyCalibration(const RobotModel& model, const CompensationStudyOptions& o, Rng* rng) {
  Eigen::VectorXd errors(model.num_error_parameters());
  for (int k = 0; k < errors.size(); ++k) {
    errors[k] = (RobotModel::IsTranslationParameter(k) ? o.error_mm : o.error_rad) * rng->Normal();
  }
  const int tool_site = 6 * (model.num_error_sites() - 1);
  return Calibration{.model = model,
                     .errors = errors,
                     .parameters = {},
                     .covariance = {},
                     .T_world_base = model.T_world_base() * ErrorTransform(errors.data()),
                     .T_flange_tool = model.T_flange_tool() * ErrorTransform(errors.data() + tool_site),
                     .reflectors = {},
                     .summary = {}};
}

// The smallest singular value of the nominal joint Jacobian at q in the solver's rows (orientation weighted
// 100 mm/rad), columns scaled to unit length: scale free, zero exactly at a singularity.
double MinSingular(const RobotModel& model, const Eigen::VectorXd& q, KinematicsWorkspace* ws) {
  const MeasurementType type = model.num_joints() >= 6 ? MeasurementType::kPose : MeasurementType::kPositionAxis;
  Eigen::MatrixXd j(MeasurementRows(type), model.num_joints());
  JointJacobian(model, q, Eigen::VectorXd(), type, ws, j);
  j.bottomRows(j.rows() - 3) *= 100.0;
  for (int c = 0; c < j.cols(); ++c) {
    const double norm = j.col(c).norm();
    if (norm > 0.0) j.col(c) /= norm;
  }
  return Eigen::JacobiSVD<Eigen::MatrixXd>(j).singularValues().minCoeff();
}

// From q, a coordinate descent on the smallest singular value (steps 0.5 deg down to 0.01 deg, at most 10 deg
// from q in any joint); the joint-space distance (max over joints, deg) to the first point below `threshold`,
// or -1 if the descent stops above it.
double DistanceToSingularity(const RobotModel& model, const Eigen::VectorXd& q, double threshold,
                             KinematicsWorkspace* ws) {
  Eigen::VectorXd x = q;
  double value = MinSingular(model, x, ws);
  for (double step = 0.5 / kDegPerRad; step >= 0.01 / kDegPerRad && value >= threshold; step /= 2.0) {
    for (bool improved = true; improved && value >= threshold;) {
      improved = false;
      for (int i = 0; i < x.size() && value >= threshold; ++i) {
        if (model.joint_type(i) != JointType::kRevolute) continue;
        for (double sign : {1.0, -1.0}) {
          Eigen::VectorXd y = x;
          y[i] += sign * step;
          if ((y - q).cwiseAbs().maxCoeff() > 10.0 / kDegPerRad) continue;
          const double v = MinSingular(model, y, ws);
          if (v < value) {
            x = y;
            value = v;
            improved = true;
            break;
          }
        }
      }
    }
  }
  return value < threshold ? (x - q).cwiseAbs().maxCoeff() * kDegPerRad : -1.0;
}

// The smallest move of one revolute joint (deg, steps of 0.02 deg, at most 10 deg) that changes a flag of the
// configuration, or -1 if none does.
double DistanceToBoundary(const ArmSolver& arm, const Eigen::VectorXd& q) {
  const ArmConfiguration own = arm.ConfigurationOf(q);
  for (int step = 1; step <= 500; ++step) {
    for (int i = 0; i < q.size(); ++i) {
      for (double sign : {1.0, -1.0}) {
        Eigen::VectorXd moved = q;
        moved[i] += sign * step * 0.02 / kDegPerRad;
        if (arm.ConfigurationOf(moved) != own) return step * 0.02;
      }
    }
  }
  return -1.0;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

void JointCommands(const Calibration& calibration, const RobotModel& nominal, const CompensationStudyOptions& o,
                   Rng* rng, CompensationStudyRow* row) {
  std::vector<CompensationTarget> targets(o.joint_targets);
  for (CompensationTarget& t : targets) t.joints = RandomConfiguration(nominal, rng);
  const std::vector<CompensationResult> results = CompensateAll(calibration, nominal, targets, {}, o.threads);
  KinematicsWorkspace ws(nominal);
  std::vector<double> iterations, converged_sigma, failed_sigma;
  std::vector<std::size_t> no_convergence;
  row->joint_targets = o.joint_targets;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const CompensationResult& r = results[i];
    if (r.converged) {
      ++row->joint_converged;
      iterations.push_back(r.iterations);
      if (converged_sigma.size() < 2000) converged_sigma.push_back(MinSingular(nominal, targets[i].joints, &ws));
    } else if (r.termination == Termination::kDegraded) {
      ++row->joint_degraded;  // a joint held at its limit: the limit, not a singularity, is in the way
    } else {
      ++row->joint_no_convergence;
      no_convergence.push_back(i);
    }
  }
  row->joint_median_iterations = Median(iterations);
  row->converged_median_min_singular = Median(converged_sigma);
  const std::optional<ArmSolver> arm = ArmSolver::For(nominal);
  for (std::size_t i : no_convergence) {
    if (arm) {
      const double boundary = DistanceToBoundary(*arm, targets[i].joints);
      if (boundary >= 0.0 && boundary <= 1.0) ++row->boundary_within_1deg;
      if (boundary >= 0.0 && boundary <= 5.0) ++row->boundary_within_5deg;
      row->boundary_max_distance_deg = boundary < 0.0 || row->boundary_max_distance_deg < 0.0
                                           ? -1.0
                                           : std::max(row->boundary_max_distance_deg, boundary);
    }
    failed_sigma.push_back(MinSingular(nominal, targets[i].joints, &ws));
    const double distance =
        DistanceToSingularity(nominal, targets[i].joints, 1e-2 * row->converged_median_min_singular, &ws);
    if (distance >= 0.0 && distance <= 1.0) ++row->no_convergence_within_1deg;
    if (distance >= 0.0 && distance <= 5.0) ++row->no_convergence_within_5deg;
    row->no_convergence_max_distance_deg = distance < 0.0 || row->no_convergence_max_distance_deg < 0.0
                                               ? -1.0
                                               : std::max(row->no_convergence_max_distance_deg, distance);
  }
  row->no_convergence_median_min_singular = Median(failed_sigma);
}

void CartesianTargets(const Calibration& calibration, const RobotModel& nominal, const ArmSolver& arm,
                      const CompensationStudyOptions& o, Rng* rng, CompensationStudyRow* row) {
  const FoldedChain calibrated(calibration.model, calibration.errors);
  std::vector<CompensationTarget> named(o.cartesian_targets), bare(o.cartesian_targets);
  for (int i = 0; i < o.cartesian_targets; ++i) {
    const Eigen::VectorXd q = RandomConfiguration(nominal, rng);
    named[i].pose = bare[i].pose = calibrated.Forward(q, nullptr);
    named[i].configuration = arm.ConfigurationOf(q);
  }
  const std::vector<CompensationResult> on_branch = CompensateAll(calibration, nominal, named, {}, o.threads);
  const std::vector<CompensationResult> no_hint = CompensateAll(calibration, nominal, bare, {}, o.threads);
  row->cartesian_targets = o.cartesian_targets;
  for (int i = 0; i < o.cartesian_targets; ++i) {
    const CompensationResult& r = on_branch[i];
    const bool same = r.configuration && *r.configuration == named[i].configuration;
    if (r.configuration && !same) ++row->cartesian_other_branch;
    if (r.converged && same) ++row->cartesian_on_branch;
    if (no_hint[i].converged) {
      ++row->cartesian_default_solved;
      if (*no_hint[i].configuration == ArmConfiguration{1, 1, 1}) ++row->cartesian_default_branch;
    }
  }
}

// A smooth path between two random configurations of one branch (a straight line in joint space plus a slow
// wave), kept only if every point of it has the branch of its start: a path that crosses a singularity changes
// branch for real. The program is the calibrated robot's poses along it; only the first target has a start.
void SmoothPath(const Calibration& calibration, const RobotModel& nominal, const ArmSolver& arm,
                const CompensationStudyOptions& o, Rng* rng, CompensationStudyRow* row) {
  const FoldedChain calibrated(calibration.model, calibration.errors);
  const int n = nominal.num_joints();
  std::vector<Eigen::VectorXd> path;
  for (int attempt = 0; attempt < 1000 && path.empty(); ++attempt) {
    const Eigen::VectorXd a = RandomConfiguration(nominal, rng), b = RandomConfiguration(nominal, rng);
    Eigen::VectorXd phase(n);
    for (int i = 0; i < n; ++i) phase[i] = rng->Uniform(0.0, 2.0 * std::numbers::pi);
    const ArmConfiguration branch = arm.ConfigurationOf(a);
    KinematicsWorkspace ws(nominal);
    bool kept = true;
    for (int k = 0; k < o.path_targets && kept; ++k) {
      const double s = o.path_targets > 1 ? static_cast<double>(k) / (o.path_targets - 1) : 0.0;
      Eigen::VectorXd q = a + (b - a) * s;
      for (int i = 0; i < n; ++i) q[i] += 0.1 * std::sin(2.0 * std::numbers::pi * s + phase[i]);
      q = q.cwiseMax(nominal.lower_limits()).cwiseMin(nominal.upper_limits());
      // The same branch all along, and not within reach of its boundary.
      kept = arm.ConfigurationOf(q) == branch && MinSingular(nominal, q, &ws) > 0.05;
      path.push_back(q);
    }
    if (!kept) path.clear();
  }
  if (path.empty()) throw std::runtime_error("no smooth path on one branch found for " + nominal.name());
  std::vector<CompensationTarget> program(path.size());
  for (std::size_t k = 0; k < path.size(); ++k) program[k].pose = calibrated.Forward(path[k], nullptr);
  program[0].start = path[0];
  const std::vector<CompensationResult> results = CompensateSequence(calibration, nominal, program);
  row->path_targets = static_cast<int>(path.size());
  for (std::size_t k = 0; k < results.size(); ++k) {
    const CompensationResult& r = results[k];
    if (!r.converged) continue;
    ++row->path_converged;
    row->path_max_deviation_deg = std::max(row->path_max_deviation_deg, (r.joints - path[k]).cwiseAbs().maxCoeff() * kDegPerRad);
    if (k == 0 || results[k - 1].joints.size() != n) continue;
    if (*r.configuration != *results[k - 1].configuration) ++row->path_branch_changes;
    row->path_max_joint_step_deg =
        std::max(row->path_max_joint_step_deg, (r.joints - results[k - 1].joints).cwiseAbs().maxCoeff() * kDegPerRad);
  }
}

std::string Percent(int part, int whole) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f %%", whole > 0 ? 100.0 * part / whole : 0.0);
  return text;
}

}  // namespace

RobotModelSpec Ur10LikeMdhSpec() {
  // The UR10's published standard DH lengths (d1 127.3, a2 -612, a3 -572.3, d4 163.941, d5 115.7, d6 92.2 mm)
  // rewritten in modified DH: row i holds alpha_{i-1}, a_{i-1} of the standard row before it, and d_i.
  RobotModelSpec s;
  s.name = "ur10_mdh";
  s.convention = GeometryConvention::kModifiedDh;
  const double limit = 170.0 * kRadPerDeg;
  const double pi2 = std::numbers::pi / 2.0;
  struct Row {
    double alpha, a, d;
  };
  const Row rows[] = {{0.0, 0.0, 127.3},      {pi2, 0.0, 0.0},   {0.0, -612.0, 0.0},
                      {0.0, -572.3, 163.941}, {pi2, 0.0, 115.7}, {-pi2, 0.0, 92.2}};
  for (int i = 0; i < 6; ++i) {
    JointSpec j;
    j.name = "joint" + std::to_string(i + 1);
    j.alpha_rad = rows[i].alpha;
    j.a_mm = rows[i].a;
    j.d_mm = rows[i].d;
    j.min = -limit;
    j.max = limit;
    s.joints.push_back(j);
  }
  s.T_flange_tool = Translation(30.0, 0.0, 120.0);
  return s;
}

bool CompensationStudyOptions::IsValid(std::string* error) const {
  if (robots.empty()) *error = "no robots";
  else if (joint_targets < 0 || cartesian_targets < 0 || path_targets < 0) *error = "target counts must be >= 0";
  else if (!(error_mm >= 0.0) || !(error_rad >= 0.0)) *error = "error sizes must be >= 0";
  else if (threads < 0) *error = "threads must be >= 0";
  else return true;
  return false;
}

CompensationStudyResult RunCompensationStudy(const CompensationStudyOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("CompensationStudyOptions: " + error);
  const auto start = std::chrono::steady_clock::now();
  CompensationStudyResult result;
  for (const std::string& name : options.robots) {
    const RobotModel model = StudyRobot(name);
    Rng rng(options.seed);
    const Calibration calibration = StudyCalibration(model, options, &rng);
    CompensationStudyRow row;
    row.robot = name;
    const std::optional<ArmSolver> arm = ArmSolver::For(model);
    row.named_branches = arm.has_value();
    if (options.joint_targets > 0) JointCommands(calibration, model, options, &rng, &row);
    if (arm && options.cartesian_targets > 0) CartesianTargets(calibration, model, *arm, options, &rng, &row);
    if (arm && options.path_targets > 0) SmoothPath(calibration, model, *arm, options, &rng, &row);
    result.rows.push_back(row);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

std::string FormatCompensationStudy(const CompensationStudyResult& result) {
  std::ostringstream out;
  char line[512];
  for (const CompensationStudyRow& r : result.rows) {
    out << r.robot << (r.named_branches ? " (named branches)" : " (no named branches)") << "\n";
    if (r.joint_targets > 0) {
      std::snprintf(line, sizeof(line),
                    "  joint commands: %d, converged %s (median %.0f iterations), DEGRADED (a joint at its limit) %d, "
                    "NO_CONVERGENCE %d\n",
                    r.joint_targets, Percent(r.joint_converged, r.joint_targets).c_str(), r.joint_median_iterations,
                    r.joint_degraded, r.joint_no_convergence);
      out << line;
      if (r.joint_no_convergence > 0) {
        std::snprintf(line, sizeof(line),
                      "    NO_CONVERGENCE: smallest singular value median %.4f (converged %.4f); a singularity within "
                      "1 deg for %d, within 5 deg for %d; farthest %s\n",
                      r.no_convergence_median_min_singular, r.converged_median_min_singular,
                      r.no_convergence_within_1deg, r.no_convergence_within_5deg,
                      r.no_convergence_max_distance_deg < 0.0
                          ? "none within 10 deg"
                          : (std::to_string(r.no_convergence_max_distance_deg).substr(0, 5) + " deg").c_str());
        out << line;
      }
      if (r.joint_no_convergence > 0 && r.named_branches) {
        std::snprintf(line, sizeof(line),
                      "    NO_CONVERGENCE: a branch boundary (one joint moved) within 1 deg for %d, within 5 deg for "
                      "%d; farthest %s\n",
                      r.boundary_within_1deg, r.boundary_within_5deg,
                      r.boundary_max_distance_deg < 0.0
                          ? "none within 10 deg"
                          : (std::to_string(r.boundary_max_distance_deg).substr(0, 5) + " deg").c_str());
        out << line;
      }
    }
    if (r.cartesian_targets > 0) {
      std::snprintf(line, sizeof(line),
                    "  Cartesian targets: %d, converged on the named branch %s, on another branch %d; without a hint "
                    "solved %s, on front/up/noflip %s\n",
                    r.cartesian_targets, Percent(r.cartesian_on_branch, r.cartesian_targets).c_str(),
                    r.cartesian_other_branch, Percent(r.cartesian_default_solved, r.cartesian_targets).c_str(),
                    Percent(r.cartesian_default_branch, r.cartesian_targets).c_str());
      out << line;
    }
    if (r.path_targets > 0) {
      std::snprintf(line, sizeof(line),
                    "  smooth path: %d targets, converged %d, branch changes %d, largest joint step %.3f deg, "
                    "largest deviation from the path's joints %.3f deg\n",
                    r.path_targets, r.path_converged, r.path_branch_changes, r.path_max_joint_step_deg,
                    r.path_max_deviation_deg);
      out << line;
    }
  }
  return out.str();
}

}  // namespace robocal

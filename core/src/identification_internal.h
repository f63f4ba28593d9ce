// What the parts of the identification share (core/src only; the public interface is identification.h and
// fit_diagnostics.h): the shots grouped by pose, the weighted least-squares problem, the Levenberg-Marquardt loop,
// the covariance of a fit, and the choice of parameters. The parts: least_squares.cc (the problem),
// levenberg_marquardt.cc (the solver loop and the covariance), registration.cc (tracker -> base), identification.cc
// (parameters, one fit, reports), robust_fit.cc (model error, outliers: Identify), fit_diagnostics.cc (residuals,
// linearisation, chi-square).
#pragma once

#include <Eigen/Core>
#include <chrono>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "robocal/core/identification.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/reflectors.h"

namespace robocal::identification_detail {

using Clock = std::chrono::steady_clock;

inline double Seconds(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

inline bool AllFinite(const Eigen::MatrixXd& m) { return m.allFinite(); }

// Shortest readable form (1e-12, not std::to_string's 0.000000).
std::string Num(double value);

// Checks the parts of a measurement that `type` uses; an empty string if it is usable.
std::string CheckMeasurement(const Measurement& m, MeasurementType type);

// Shots grouped by joint configuration and reflector: a group shares its kinematics (and its robot
// repeatability error); distinct groups bound the information.
struct ShotGroups {
  struct Group {
    int pose = 0;
    int reflector = -1;
    std::vector<int> shots;
  };
  std::vector<Eigen::VectorXd> poses;  // distinct joint configurations (under distinct payloads)
  std::vector<Payload> payloads;       // per pose
  std::vector<Group> groups;
  std::vector<int> group_of;  // per measurement

  explicit ShotGroups(const std::vector<Measurement>& measurements) {
    std::map<Eigen::VectorXd, int, LexicographicLess> pose_index;
    std::map<std::pair<int, int>, int> group_index;
    group_of.reserve(measurements.size());
    for (size_t i = 0; i < measurements.size(); ++i) {
      const Measurement& m = measurements[i];
      // A pose is a configuration under a payload: the same joints under another payload deflect otherwise.
      const auto [pose, new_pose] = pose_index.emplace(PoseKey(m), static_cast<int>(poses.size()));
      if (new_pose) {
        poses.push_back(m.joints);
        payloads.push_back(m.payload);
      }
      const auto [group, new_group] =
          group_index.emplace(std::make_pair(pose->second, m.reflector), static_cast<int>(groups.size()));
      if (new_group) groups.push_back({pose->second, m.reflector, {}});
      groups[group->second].shots.push_back(static_cast<int>(i));
      group_of.push_back(group->second);
    }
  }
};

// The least-squares problem over the chosen parameters (the model's error parameters, then 3 offset errors per
// reflector: reflectors.h's index space). Shots are grouped by joint configuration and reflector; a group
// shares its kinematics and Jacobian, so the cost of an evaluation grows with the groups, not with the shots.
class Problem {
 public:
  Problem(const RobotModel& model, const std::vector<Measurement>& measurements, const ShotGroups& shot_groups,
          const IdentificationOptions& o, const std::vector<int>& parameters);

  // The measurements' rows, then the penalty rows: the joint maps' (JointMapTerms: each map's second differences,
  // weighted) and the priors' (x_k / sigma_k per parameter with a prior), which Evaluate appends.
  int num_rows() const { return num_measurement_rows() + static_cast<int>(penalty_.rows()); }
  int num_measurement_rows() const { return rows_ * static_cast<int>(measurements_.size()); }
  // The penalty rows over the chosen parameters (num_penalty_rows x num_parameters; none without maps).
  const Eigen::MatrixXd& penalty() const { return penalty_; }
  // P'P of the penalty rows (num_parameters square; empty without maps and priors).
  const Eigen::MatrixXd& penalty_normal() const { return penalty_normal_; }
  // Per chosen parameter its prior standard deviation (+infinity: none); empty without priors.
  const Eigen::VectorXd& prior_std() const { return prior_std_; }
  int num_parameters() const { return static_cast<int>(parameters_.size()); }

  // The model's error parameters (num_error_parameters) and the reflectors' offset errors (3 each) at x.
  Eigen::VectorXd FullErrors(const Eigen::VectorXd& x) const {
    Eigen::VectorXd eps = Eigen::VectorXd::Zero(n_model_);
    for (int k = 0; k < num_parameters(); ++k)
      if (parameters_[k] < n_model_) eps[parameters_[k]] = x[k];
    return eps;
  }
  Eigen::VectorXd ReflectorErrors(const Eigen::VectorXd& x) const {
    Eigen::VectorXd out = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(reflectors_.size()));
    for (int k = 0; k < num_parameters(); ++k)
      if (parameters_[k] >= n_model_) out[parameters_[k] - n_model_] = x[k];
    return out;
  }

  const std::vector<ShotGroups::Group>& groups() const { return groups_; }
  const std::vector<int>& group_of() const { return group_of_; }

  // Weighted residuals r (num_rows) at reduced parameters x and, if `jacobian` is not null, the weighted
  // Jacobian of the model prediction (num_rows x num_parameters), so that r(x + d) ~= r(x) - J d.
  void Evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* residual, Eigen::MatrixXd* jacobian);

  // Per group: the model's prediction at reduced parameters x and, if `group_jacobian` is not null, its
  // Jacobian over the chosen parameters, unweighted (rows x num_parameters).
  void Predict(const Eigen::VectorXd& x, std::vector<Transform>* prediction,
               std::vector<Eigen::MatrixXd>* group_jacobian);

  // What Predict gave with the Jacobian at the last Evaluate that asked for one, if that was at `x` bit for bit:
  // moved into the outputs (true); false otherwise (a rejected step's prediction does not count).
  bool TakeJacobianAt(const Eigen::VectorXd& x, std::vector<Transform>* prediction,
                      std::vector<Eigen::MatrixXd>* group_jacobian);

 private:
  using Group = ShotGroups::Group;
  struct GroupWhitening {
    Eigen::MatrixXd mean;
    Eigen::MatrixXd contrast;
  };

  // Per chosen parameter: the squared norm of its column of the weighted Jacobian at zero (the maps' penalty
  // scale).
  Eigen::VectorXd ColumnInformation();
  // The joint maps' penalty rows over the chosen parameters (the constructor's comment says which); appended to
  // `rows`.
  void AddMapRows(std::vector<Eigen::RowVectorXd>* rows);

  // Rows of the repeatability model (see the constructor): per group, sqrt(n) times the mean residual of its n
  // shots whitened by `mean`, then the n - 1 Helmert contrasts whitened by `contrast` (no parameter moves them).
  void EvaluateByGroup(const std::vector<Transform>& prediction, const std::vector<Eigen::MatrixXd>& group_jacobian,
                       Eigen::VectorXd* residual, Eigen::MatrixXd* jacobian) const;

  const RobotModel& model_;
  const std::vector<Measurement>& measurements_;
  MeasurementType type_;
  int rows_;
  Eigen::VectorXd weights_;
  std::vector<int> parameters_;
  std::vector<Reflector> reflectors_;
  int n_model_;
  KinematicsWorkspace ws_;
  const std::vector<Eigen::VectorXd>& poses_;
  const std::vector<Group>& groups_;
  const std::vector<int>& group_of_;
  std::vector<Eigen::MatrixXd> whitening_;       // per measurement, with a tracker model and no repeatability
  std::vector<GroupWhitening> group_whitening_;  // per group, with repeatability
  std::vector<PreparedDeflection> prepared_;     // per pose: its deflection's parts that do not depend on x
  Eigen::MatrixXd penalty_;                      // the maps' penalty rows (constant: the penalty is linear)
  Eigen::MatrixXd penalty_normal_;               // their P'P
  Eigen::VectorXd prior_std_;                    // per chosen parameter (priors only)
  // Kept between evaluations so that they allocate once per fit, not once per pose and evaluation (a fit evaluates
  // some tens of times, a cross-validated model choice some thousands): per pose its Jacobian (its rows x n_model_,
  // side by side) and tool pose; Evaluate's predictions and Jacobians per group.
  Eigen::MatrixXd pose_full_;
  std::vector<Transform> pose_model_;
  std::vector<Transform> prediction_;
  std::vector<Eigen::MatrixXd> group_jacobian_;
  // Where group_jacobian_ was evaluated by Evaluate (empty: not by it), and the prediction there.
  Eigen::VectorXd jacobian_x_;
  std::vector<Transform> jacobian_prediction_;
};

// A fit's linearisation at its solution `x`, as its own problem evaluated it there (IdentifyOnce's
// `at_solution`): each group's prediction and unweighted Jacobian (Problem::Predict) and the inverse information
// (J'J + P)^-1 before sigma_hat^2 scales it (empty where the fit formed it from the normal matrix). The robust fit's
// model-error estimate and studentised residuals take them instead of evaluating the same point again.
struct SolutionLinearisation {
  Eigen::VectorXd x;
  std::vector<Transform> prediction;
  std::vector<Eigen::MatrixXd> group_jacobian;
  Eigen::MatrixXd inverse_information;

  // Whether it is the linearisation at `at` (bit for bit) with the Jacobians.
  bool At(const Eigen::VectorXd& at) const {
    return !group_jacobian.empty() && x.size() == at.size() && (x.array() == at.array()).all();
  }
};

// A fit's start, evaluated once: the rank test judges its Jacobian and the solver starts from it.
struct FitStart {
  Eigen::VectorXd x;
  Eigen::VectorXd residual;
  Eigen::MatrixXd jacobian;
};
// From `x0` (the reduced parameters of a fit of nearly the same problem: the model error's cycles, the robust
// rounds) when it has the problem's size and is finite, else from zero.
FitStart EvaluateStart(Problem* problem, const Eigen::VectorXd* x0);

struct LmResult {
  Eigen::VectorXd x;
  Eigen::VectorXd residual;
  Eigen::MatrixXd jacobian;
  // J'J at x (NormalMatrix(jacobian)), for the covariance; empty if the loop ended before forming it.
  Eigen::MatrixXd normal;
  int iterations = 0;
  Termination termination = Termination::kNoConvergence;
  std::string reason;
  bool cancelled = false;  // the progress callback asked to stop
};

// Levenberg-Marquardt, written here rather than taken from Eigen's unsupported module because (a) the
// Summary promises the Ceres-style tests of IdentificationOptions (relative cost change, max |J'r|, step
// relative to |x|), which MINPACK's ftol/xtol/gtol define differently (gtol there is a cosine), (b) shots of
// one pose share one Jacobian evaluation (Problem), and (c) the loop is 40 lines with Nielsen's damping update
// and Marquardt's diag(J'J) scaling, so it is scale invariant in mm and rad. Normal equations are safe here:
// they are formed from column-scaled J, whose condition number is checked before the loop (rank test).
// From `start` (EvaluateStart), whose storage it keeps for its own Jacobian: at hundreds of parameters a Jacobian
// is megabytes, and fresh memory costs more to touch than to fill.
LmResult LevenbergMarquardt(Problem* problem, const IdentificationOptions& o, FitStart start);

// Beyond this many parameters (joint maps: some hundreds, each touching a few poses) the normal matrix J'J is summed
// over each row's non-zero entries, and the covariance comes from the scaled normal matrix's eigenvalues and
// Cholesky factor instead of an SVD of J (seconds at 500 columns).
inline constexpr int kDenseParameterLimit = 150;
// The normal equations resolve singular values down to about 1e-7 of the largest: with more than
// kDenseParameterLimit parameters the rank cut is at least that.
inline constexpr double kNormalRankTolerance = 1e-7;

// J'J: by a matrix product, or over each block of rows' non-zero columns beyond kDenseParameterLimit columns.
Eigen::MatrixXd NormalMatrix(const Eigen::MatrixXd& jacobian);

// Whether the column-scaled J has its full column rank by the Cholesky factor of its normal matrix: its estimated
// reciprocal condition number (of J'J, the squared singular values' ratio) above tolerance^2. A quick test for the
// many parameters of joint maps; no singular values.
bool FullRankByNormal(const Eigen::MatrixXd& jacobian, double tolerance);

// The columns of j with a non-zero entry, ascending, and j's part of them.
std::vector<int> NonzeroColumns(const Eigen::MatrixXd& j);
Eigen::MatrixXd ColumnsOf(const Eigen::MatrixXd& j, const std::vector<int>& columns);

// Singular values and covariance of a weighted Jacobian through its column-scaled form Js = J D (unit columns):
// (J'J)^-1 = D (Js'Js)^-1 D. False, with nothing written, when Js is rank deficient: no covariance exists.
// The fit and LinearizeFit share it, so a report's recomputed figures are the fit's.
bool ScaledCovariance(const Eigen::MatrixXd& jacobian, double sigma_hat, double rank_tolerance,
                      Eigen::VectorXd* singular_values, Eigen::MatrixXd* covariance);
// The same from J'J itself (beyond kDenseParameterLimit parameters, where it is formed from the normal matrix).
bool ScaledCovarianceOfNormal(const Eigen::MatrixXd& normal, double sigma_hat, double rank_tolerance,
                              Eigen::VectorXd* singular_values, Eigen::MatrixXd* covariance);

// The effective number of parameters of a fit with penalty rows P: tr(N^-1 J'J) = n - tr(N^-1 P'P), where N is the
// information with the penalty (`inverse` = N^-1, the covariance at unit sigma) and `penalty_normal` P'P (empty:
// no penalty rows, n).
double EffectiveParameters(const Eigen::MatrixXd& inverse, const Eigen::MatrixXd& penalty_normal);

// Which parameters a fit estimates, chosen once for the robust fit's rounds.
struct ParameterSelection {
  std::vector<int> parameters;
  std::vector<DroppedParameter> dropped;
  Termination termination = Termination::kConvergence;
  std::string failure;  // non-empty: no set could be chosen
  std::string note;     // said in the fit's message
};

ParameterSelection SelectParameters(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                                    const IdentificationOptions& options);

// One weighted fit; its Levenberg-Marquardt starts from `start` (reduced parameters, the selection's order) when
// given: a refit of nearly the same problem converges in a few iterations from the last solution.
// With `at_solution`, also its linearisation at the solution (cleared when the fit fails).
Calibration IdentifyOnce(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                         const IdentificationOptions& options, const ParameterSelection& selection,
                         const Eigen::VectorXd* start = nullptr, SolutionLinearisation* at_solution = nullptr);

// A fit parameter is a translation (mm) by its name's axis: the model's and the reflectors' offsets (past the
// model's parameters, where RobotModel::IsTranslationParameter's index rule does not reach) end in .dx/.dy/.dz.
inline bool IsTranslationName(const std::string& name) {
  return name.size() > 3 && name.compare(name.size() - 3, 2, ".d") == 0;
}

}  // namespace robocal::identification_detail
